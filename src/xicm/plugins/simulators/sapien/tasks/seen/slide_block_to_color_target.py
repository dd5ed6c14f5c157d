"""slide_block_to_color_target (seen).

Task description:
    A block stands on the table with four coloured square targets (green, blue, pink, yellow)
    laid out around it, one on each side. The robot closes its gripper, puts it down behind
    the block and slides the block across the table onto the target of the named colour.

Randomisations:
    - the target colour (variation 0: green, 1: blue, 2: pink, 3: yellow) when variations are
      sampled;
    - which side of the block each colour lies on (a random permutation);
    - block centre x in [0.15, 0.30] m, y in [-0.15, 0.15] m; the layout's yaw in [-45, 45]
      degrees, the block's own yaw within 10 degrees of it.

Success conditions:
    The block's centre lies on the named target (inside its 8 cm square) with the block
    standing on the table.
"""

from __future__ import annotations

import numpy as np
import sapien


from ...objects import COLORS, add_box, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, quantised

TARGETS = ("green", "blue", "pink", "yellow")
RGB = {"green": COLORS["green"], "blue": COLORS["blue"], "pink": (0.95, 0.45, 0.70), "yellow": COLORS["yellow"]}
HALF = 0.025  # the block is a 5 cm cube
TARGET_HALF = 0.04
SPACING = 0.15  # block centre to each target centre
FINGER_HALF = 0.011  # half the closed fingers' thickness along the hand's x axis
DOWN = np.array([0.0, 1.0, 0.0, 0.0])


def down_yaw(yaw: float) -> np.ndarray:
    """Gripper pointing down, turned by `yaw` about the world z axis (hand x at that yaw)."""
    return np.asarray((sapien.Pose(q=[np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)]) * sapien.Pose(q=DOWN)).q)


class SlideBlockToColorTarget(Task):
    name = "slide_block_to_color_target"
    max_control_steps = 62  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "seen"
    instruction = "slide the block to green target"
    phrasings = (  # RLBench's variation-0 phrasings, AGNOSTOS's instruction first
        "slide the block to green target",
        "slide the block onto the green square",
        "push the block until it is sitting on top of the green target",
        "slide the block towards the green plane",
        "cover the green target with the block by pushing the block in its direction",
    )
    object_names = ("block", "green target", "blue target", "pink target", "yellow target")

    def load(self) -> None:
        b = self.world.scene.create_actor_builder()
        add_box(b, [HALF] * 3, color=(0.55, 0.35, 0.20), material=physical(0.5), density=400.0)
        self.block = self.objects.actor(b, "block")
        self.targets = []
        for colour in TARGETS:
            b = self.world.scene.create_actor_builder()
            # a flat coloured square just above the table top, no collision (the block slides over it)
            add_box(b, [TARGET_HALF, TARGET_HALF, 0.0005], sapien.Pose([0, 0, 0.0006]), RGB[colour], collide=False)
            self.targets.append(self.objects.actor(b, f"{colour} target", kind="static"))

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        variation = int(rng.integers(len(TARGETS)))
        self.variation = variation if sample_variation else 0
        self.episode_instruction = f"slide the block to {TARGETS[self.variation]} target"
        centre = np.array([rng.uniform(0.15, 0.30), rng.uniform(-0.15, 0.15)])
        layout = np.deg2rad(rng.uniform(-45.0, 45.0))
        sides = rng.permutation(4)
        for colour, side in zip(range(4), sides):
            a = layout + side * np.pi / 2
            p = centre + SPACING * np.array([np.cos(a), np.sin(a)])
            self.targets[colour].set_pose(yaw_pose(p[0], p[1], TABLE_TOP_Z, layout))
        block_yaw = layout + np.deg2rad(rng.uniform(-10.0, 10.0))
        self.block.set_pose(yaw_pose(centre[0], centre[1], TABLE_TOP_Z + HALF, block_yaw))

    def on_target(self, index: int) -> bool:
        local = (self.targets[index].pose.inv() * self.block.pose).p
        return bool(abs(local[0]) < TARGET_HALF and abs(local[1]) < TARGET_HALF and abs(local[2] - HALF) < 0.01)

    def evaluate(self) -> bool:
        return self.on_target(self.variation)

    def demonstration(self):
        block = np.asarray(self.block.pose.p, dtype=float)
        target = np.asarray(self.targets[self.variation].pose.p, dtype=float)
        push = target[:2] - block[:2]
        u = np.array([*push / np.linalg.norm(push), 0.0])
        yaw = (np.arctan2(u[1], u[0]) + np.pi / 2) % np.pi - np.pi / 2  # hand x along the push
        q = down_yaw(yaw)
        z = TABLE_TOP_Z + 0.02  # fingertips 1 cm above the table
        start = np.array([block[0], block[1], z]) - u * (HALF + FINGER_HALF + 0.03)
        end = np.array([target[0], target[1], z]) - u * (HALF + FINGER_HALF - 0.005)
        yield quantised(self.key(start + [0, 0, 0.10], q, False))
        yield quantised(self.key(start, q, False))
        yield quantised(self.key(end, q, False))
        yield quantised(self.key(end + [0, 0, 0.10], q, False))
