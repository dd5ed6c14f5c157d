"""stack_cups (seen).

Task description:
    Three tapered cups (red, green and blue) stand upright on the table. The robot picks the
    two cups that are not of the named colour up by their rims, one after the other, and drops
    them into the named cup so that all three are nested in one stack.

Randomisations:
    - the colour of the cup to stack on (variation 0: red; red, green or blue when variations
      are sampled);
    - cup centres in x in [0.12, 0.34] m, y in [-0.24, 0.24] m, at least 0.14 m apart.

Success conditions:
    Both other cups sit inside the named cup (centres within 2 cm of its axis, bottoms above
    its bottom and below its rim) AND nothing is grasped.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, physical
from ...scene import TABLE_TOP_Z
from ...task_base import Task, snap_to_grid

COLOURS = ("red", "green", "blue")
R_BOTTOM, R_TOP, HEIGHT = 0.025, 0.045, 0.075  # outer radius at the bottom / rim, height
WALL = 0.004
BASE = 0.004  # bottom plate thickness
SEGMENTS = 16
SLOPE = (R_TOP - R_BOTTOM) / HEIGHT
GRIP_DEPTH = 0.015  # the TCP this far below the rim when grasping
CARRY = 0.20  # carried cup's bottom this high above the table over the stack
DROP = 0.03  # release the cup this far above where it nests (fingertips then clear its rim)


def wall_radius(z: float) -> float:
    """Radius of the middle of the wall at height z above the cup's bottom."""
    return R_BOTTOM + SLOPE * z - WALL / 2


def cell_centre(z: float) -> float:
    """The height of the 1 cm text-grid cell centre that holds z."""
    return float(snap_to_grid((0.0, 0.0, z))[2])


class StackCups(Task):
    name = "stack_cups"
    max_control_steps = 152  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "seen"
    instruction = "stack the other cups on top of the red cup"
    phrasings = (  # RLBench's variation-0 phrasings, AGNOSTOS's instruction first
        "stack the other cups on top of the red cup",
        "place two of the cups onto the odd cup out",
        "put the remaining two cups on top of the red cup",
        "pick up and set the cups down into the red cup",
        "create a stack of cups with the red cup as its base",
        "keeping the red cup on the table, stack the other two onto it",
    )
    object_names = ("red cup", "green cup", "blue cup")

    def _build_cup(self, colour: str) -> sapien.Entity:
        b = self.world.scene.create_actor_builder()
        mat = physical(0.6)
        add_cylinder(b, R_BOTTOM - 0.001, BASE / 2, sapien.Pose([0, 0, BASE / 2]), colour, material=mat, density=600.0)
        alpha = np.arctan(SLOPE)
        length = np.hypot(HEIGHT, R_TOP - R_BOTTOM)
        r_mid = (R_BOTTOM + R_TOP) / 2 - WALL / 2
        width = 2 * (r_mid + WALL / 2) * np.tan(np.pi / SEGMENTS) * 1.02
        for k in range(SEGMENTS):
            phi = 2 * np.pi * k / SEGMENTS
            rz = sapien.Pose(q=[np.cos(phi / 2), 0, 0, np.sin(phi / 2)])
            ry = sapien.Pose(q=[np.cos(alpha / 2), 0, np.sin(alpha / 2), 0])
            pose = sapien.Pose([r_mid * np.cos(phi), r_mid * np.sin(phi), HEIGHT / 2]) * rz * ry
            add_box(b, [WALL / 2, width / 2, length / 2], pose, colour, material=mat, density=600.0)
        return self.objects.actor(b, f"{colour} cup")

    def load(self) -> None:
        self.cups = [self._build_cup(c) for c in COLOURS]

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        variation = int(rng.integers(len(COLOURS)))
        self.variation = variation if sample_variation else 0
        self.episode_instruction = f"stack the other cups on top of the {COLOURS[self.variation]} cup"
        positions: list[np.ndarray] = []
        while len(positions) < len(self.cups):
            p = np.array([rng.uniform(0.12, 0.34), rng.uniform(-0.24, 0.24)])
            if all(np.linalg.norm(p - q) >= 0.14 for q in positions):
                positions.append(p)
        for cup, p in zip(self.cups, positions):
            cup.set_pose(sapien.Pose([p[0], p[1], TABLE_TOP_Z + 0.0005]))

    def inside(self, cup: int, base: int) -> bool:
        """Whether cup `cup` is nested in cup `base` (directly or with a cup between them)."""
        p = np.asarray(self.cups[cup].pose.p)
        b = np.asarray(self.cups[base].pose.p)
        upright = self.cups[cup].pose.to_transformation_matrix()[2, 2] > 0.95
        return bool(upright and np.linalg.norm(p[:2] - b[:2]) < 0.02 and b[2] + 0.003 < p[2] < b[2] + HEIGHT - 0.02)

    def evaluate(self) -> bool:
        others = [i for i in range(len(self.cups)) if i != self.variation]
        if not all(self.inside(i, self.variation) for i in others):
            return False
        ids = {c.per_scene_id for c in self.cups}
        return not (self.grasped() & ids)

    def demonstration(self):
        """Few key poses (X-ICM prompts carry every key action): the first grasp comes straight
        from the start pose, carries go diagonally up to high above the stack, and each cup is
        let go high enough for the fingertips to clear every rim, so the hand leaves sideways."""
        base = np.asarray(self.cups[self.variation].pose.p)
        others = [i for i in range(len(self.cups)) if i != self.variation]
        # the nearer cup first: the farther one's carry path is then free of standing cups
        others.sort(key=lambda i: float(np.linalg.norm(np.asarray(self.cups[i].pose.p)[:2] - base[:2])))
        top = self.variation  # the cup at the top of the stack
        for n, i in enumerate(others):
            cup = np.asarray(self.cups[i].pose.p)
            z_grip = cell_centre(cup[2] + HEIGHT - GRIP_DEPTH)
            rim = cup + [0.0, -wall_radius(z_grip - cup[2]), 0.0]  # the rim on the cup's -y side
            grasp = np.array([rim[0], rim[1], z_grip])
            if n > 0:
                yield self.key(grasp + [0, 0, 0.08], gripper_open=True)
            yield self.key(grasp, gripper_open=False)
            tcp = np.asarray(self.world.robot.tcp_pose().p)
            held = tcp - np.asarray(self.cups[i].pose.p)  # cup bottom -> TCP, while held
            stack = np.asarray(self.cups[top].pose.p)
            yield self.key(np.array([stack[0], stack[1], TABLE_TOP_Z + CARRY]) + held, gripper_open=False)
            # measured again over the stack: a cup held by its rim hangs a little tilted
            held = np.asarray(self.world.robot.tcp_pose().p) - np.asarray(self.cups[i].pose.p)
            nest = WALL / SLOPE  # how high a cup sits in another
            release = np.array([stack[0], stack[1], stack[2] + nest + DROP]) + held
            yield self.key(release, gripper_open=True)
            top = i
