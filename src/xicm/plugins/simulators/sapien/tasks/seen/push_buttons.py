"""push_buttons (seen).

Task description:
    Three coloured push buttons stand on the table. The robot closes its gripper and presses
    the named buttons, one after the other, in the order of the instruction.

Randomisations:
    - button positions anywhere in x in [0.00, 0.40] m, y in [-0.30, 0.30] m within 0.70 m
      of the robot base, at least 0.14 m apart, base yaw in [-180, 180] degrees (RLBench's
      SpawnBoundary default);
    - when variations are sampled: the three colours (from eight) and how many buttons to
      press (1 to 3) and in which order. Variation 0 is red, green, blue; press red.

Success conditions:
    The named buttons were pressed (> 1 mm) in the named order, before any other button.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task

PALETTE = ("red", "green", "blue", "yellow", "orange", "purple", "cyan", "white")
BASE_HALF = (0.04, 0.04, 0.0125)
CAP_RADIUS, CAP_HALF = 0.022, 0.01  # the cap stands CAP_HALF*2 - 0.004 above the base
TRAVEL = 0.012
PRESSED = 0.001
MAX_REACH = 0.70  # horizontal distance from the robot base within which buttons are placed


def instruction_for(colours: list[str]) -> str:
    return ", then ".join(f"push the {c} button" for c in colours)


class PushButtons(Task):
    name = "push_buttons"
    max_control_steps = 104  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "seen"
    instruction = "push the red button"
    phrasings = (  # RLBench's variation-0 phrasings, AGNOSTOS's instruction first
        "push the red button",
        "press the red button",
        "push down the button with the red base",
    )
    object_names = ("red button", "green button", "blue button")

    def load(self) -> None:
        """Nothing to build before the colours are known; see initialise()."""
        self.buttons = []

    def _build_button(self, colour: str, pose: sapien.Pose):
        ab = self.world.scene.create_articulation_builder()
        base = ab.create_link_builder()
        base.set_name("base")
        add_box(base, BASE_HALF, sapien.Pose([0, 0, BASE_HALF[2]]), (0.2, 0.2, 0.22))
        cap = ab.create_link_builder(base)
        cap.set_name("cap")
        cap.set_joint_name("press")
        # joint x axis -> world -z: q > 0 is "pressed in"
        down = sapien.Pose([0, 0, 2 * BASE_HALF[2]], [np.cos(np.pi / 4), 0, np.sin(np.pi / 4), 0])
        cap.set_joint_properties("prismatic", [[0.0, TRAVEL]], down, sapien.Pose(q=down.q), damping=2.0)
        add_cylinder(cap, CAP_RADIUS, CAP_HALF, sapien.Pose([0, 0, CAP_HALF - 0.004]), colour, density=300.0)
        name = f"{colour} button"
        art = self.objects.articulation(ab, {"base": name, "cap": name}, name, pose)
        joint = art.get_active_joints()[0]
        joint.set_drive_property(800.0, 5.0)  # a spring that pushes the cap back up
        joint.set_drive_target(0.0)
        for link in art.get_links():
            link.disable_gravity = True
        return art

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        colours = [PALETTE[i] for i in rng.choice(len(PALETTE), 3, replace=False)]
        count = int(rng.integers(1, 4))
        order = [int(i) for i in rng.permutation(3)[:count]]
        if not sample_variation:
            colours, order = ["red", "green", "blue"], [0]
        positions: list[np.ndarray] = []
        base = np.asarray(self.world.robot.base_pose.p[:2])
        while len(positions) < 3:
            p = np.array([rng.uniform(0.0, 0.40), rng.uniform(-0.30, 0.30)])
            if np.linalg.norm(p - base) > MAX_REACH:
                continue  # too far to press straight down
            if all(np.linalg.norm(p - q) >= 0.14 for q in positions):
                positions.append(p)
        yaws = rng.uniform(-np.pi, np.pi, 3)
        self.buttons = [
            self._build_button(c, yaw_pose(p[0], p[1], TABLE_TOP_Z, yaw)) for c, p, yaw in zip(colours, positions, yaws)
        ]
        self.colours = colours
        self.targets = order
        self.variation = 0 if order == [0] and colours == ["red", "green", "blue"] else 1
        self.episode_instruction = instruction_for([colours[i] for i in order])
        self.episode_object_names = [f"{c} button" for c in colours]
        self.pressed: list[int] = []

    def depths(self) -> np.ndarray:
        return np.array([float(b.get_qpos()[0]) for b in self.buttons])

    def on_frame(self) -> None:
        for i, depth in enumerate(self.depths()):
            if depth > PRESSED and i not in self.pressed:
                self.pressed.append(i)

    def evaluate(self) -> bool:
        self.on_frame()
        n = len(self.targets)
        return self.pressed[:n] == self.targets

    def demonstration(self):
        for k, i in enumerate(self.targets):
            cap = self.buttons[i].get_links()[1].entity_pose
            top = np.asarray(cap.p) + np.array([0.0, 0.0, 2 * CAP_HALF - 0.004])
            yield self.key(top + [0, 0, 0.08], gripper_open=False)
            yield self.key(top + [0, 0, 0.001], gripper_open=False)
            yield self.key(top + [0, 0, 0.08], gripper_open=False)
