"""stack_blocks (seen).

Task description:
    Four blocks of the target colour, four distractor blocks of another colour and a square
    stacking area lie on the table. The robot picks up target-colour blocks one at a time and
    stacks the named number of them into a tower on the stacking area.

Randomisations:
    - when variations are sampled: the target colour (eight colours) and the number of blocks
      to stack (2, 3 or 4), variation = colour index + 8 * (number - 2) as upstream, and a
      different colour for the distractors; without sampling: 2 red blocks, green
      distractors (variation 0, "stack 2 red blocks");
    - the eight blocks anywhere in x in [0.00, 0.36] m, y in [-0.30, 0.30] m, at least 0.10 m
      apart, each with a random yaw; the stacking area in the same region, 0.14 m clear of
      every block centre.

Success conditions:
    The named number of target-colour blocks stand stacked on the stacking area (each centre
    within 5 cm of the area's centre, their heights one block apart from the bottom layer up)
    AND nothing is grasped.
"""

from __future__ import annotations

import numpy as np
import sapien


from ...objects import add_box, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, quantised

PALETTE = ("red", "green", "blue", "yellow", "orange", "purple", "cyan", "white")
HALF = 0.02  # blocks are 4 cm cubes
AREA_HALF, AREA_T = 0.07, 0.001
SPAWN_X, SPAWN_Y = (0.00, 0.36), (-0.30, 0.30)
BLOCK_GAP, AREA_GAP = 0.10, 0.14
DOWN = np.array([0.0, 1.0, 0.0, 0.0])


def down_yaw(yaw: float) -> np.ndarray:
    """Gripper pointing down, turned by `yaw` about the world z axis."""
    return np.asarray((sapien.Pose(q=[np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)]) * sapien.Pose(q=DOWN)).q)


def instruction_for(n: int, colour: str) -> str:
    return f"stack {n} {colour} blocks"


class StackBlocks(Task):
    name = "stack_blocks"
    max_control_steps = 336  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "seen"
    instruction = "stack 2 red blocks"
    phrasings = (  # RLBench's variation-0 phrasings, AGNOSTOS's instruction first
        "stack 2 red blocks",
        "place 2 of the red cubes on top of each other",
        "pick up and set down 2 red blocks on top of each other",
        "build a tall tower out of 2 red cubes",
        "arrange 2 red blocks in a vertical stack on the table top",
        "set 2 red cubes on top of each other",
    )
    object_names = (
        *(f"red block {i}" for i in range(1, 5)),
        *(f"green block {i}" for i in range(1, 5)),
        "stacking area",
    )

    def load(self) -> None:
        """The stacking area now; the blocks in initialise(), once their colours are known."""
        b = self.world.scene.create_actor_builder()
        add_box(b, [AREA_HALF, AREA_HALF, AREA_T / 2], color=(0.22, 0.22, 0.25), material=physical(1.0))
        add_box(b, [AREA_HALF - 0.006, AREA_HALF - 0.006, 0.0002], sapien.Pose([0, 0, AREA_T / 2 + 0.0002]),
                (0.85, 0.85, 0.80), collide=False)
        add_box(b, [AREA_HALF - 0.012, AREA_HALF - 0.012, 0.0002], sapien.Pose([0, 0, AREA_T / 2 + 0.0004]),
                (0.22, 0.22, 0.25), collide=False)
        self.area = self.objects.actor(b, "stacking area", kind="static")
        self.blocks: list[sapien.Entity] = []

    def _build_block(self, colour: str, name: str, pose: sapien.Pose) -> sapien.Entity:
        b = self.world.scene.create_actor_builder()
        add_box(b, [HALF] * 3, color=colour, material=physical(1.2), density=600.0)
        return self.objects.actor(b, name, pose=pose)

    def _sample_layout(self, rng: np.random.Generator) -> tuple[np.ndarray, list[np.ndarray]]:
        while True:  # restart when the random sequential placement gets stuck
            area = np.array([rng.uniform(*SPAWN_X), rng.uniform(*SPAWN_Y)])
            spots: list[np.ndarray] = []
            for _ in range(400):
                p = np.array([rng.uniform(*SPAWN_X), rng.uniform(*SPAWN_Y)])
                if np.linalg.norm(p - area) >= AREA_GAP and all(np.linalg.norm(p - q) >= BLOCK_GAP for q in spots):
                    spots.append(p)
                    if len(spots) == 8:
                        return area, spots

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        colour = int(rng.integers(len(PALETTE)))
        count = int(rng.integers(2, 5))
        other = int(rng.choice([i for i in range(len(PALETTE)) if i != colour]))
        if not sample_variation:
            colour, count, other = 0, 2, 1
        area, spots = self._sample_layout(rng)
        yaws = rng.uniform(-np.pi, np.pi, 8)
        self.area.set_pose(sapien.Pose([area[0], area[1], TABLE_TOP_Z + AREA_T / 2]))
        self.colour, self.count = PALETTE[colour], count
        colours = [PALETTE[colour]] * 4 + [PALETTE[other]] * 4
        names = [f"{c} block {i % 4 + 1}" for i, c in enumerate(colours)]
        self.blocks = [
            self._build_block(colours[i], names[i], yaw_pose(*spots[i], TABLE_TOP_Z + HALF, yaws[i])) for i in range(8)
        ]
        self.targets = self.blocks[:4]
        self.variation = colour + len(PALETTE) * (count - 2)
        self.episode_instruction = instruction_for(count, self.colour)
        self.episode_object_names = names + ["stacking area"]

    def stacked(self) -> int:
        """Height (in blocks) of the target-colour tower standing on the stacking area."""
        centre = np.asarray(self.area.pose.p[:2])
        base = TABLE_TOP_Z + AREA_T
        levels = set()
        for block in self.targets:
            p = np.asarray(block.pose.p)
            if np.linalg.norm(p[:2] - centre) > 0.05:
                continue
            level = (p[2] - base - HALF) / (2 * HALF)
            if abs(level - round(level)) < 0.25:
                levels.add(round(level))
        height = 0
        while height in levels:
            height += 1
        return height

    def evaluate(self) -> bool:
        return self.stacked() >= self.count and not self.grasped()

    def demonstration(self):
        centre = np.asarray(self.area.pose.p, dtype=float)
        base = TABLE_TOP_Z + AREA_T
        order = sorted(self.targets, key=lambda b: float(np.linalg.norm(np.asarray(b.pose.p[:2]) - centre[:2])))
        top_xy = centre[:2]
        for level, block in enumerate(order[: self.count]):
            pose = block.pose
            p = np.asarray(pose.p, dtype=float)
            yaw = 2 * np.arctan2(pose.q[3], pose.q[0])
            yaw = (yaw + np.pi / 4) % (np.pi / 2) - np.pi / 4  # the face pair closest to the default grip
            grip_q = down_yaw(yaw)
            grasp = p + [0.0, 0.0, HALF - 0.012]
            yield quantised(self.key(grasp + [0, 0, 0.10], grip_q, True))
            yield quantised(self.key(grasp, grip_q, False))
            tcp = np.asarray(self.world.robot.tcp_pose().p, dtype=float)
            in_hand = tcp - np.asarray(block.pose.p, dtype=float)
            place = np.array([*top_xy, base + level * 2 * HALF + HALF + 0.007]) + in_hand
            carry = max(place[2] + 0.05, grasp[2] + 0.10)
            yield quantised(self.key([*grasp[:2], carry], grip_q, False))
            yield quantised(self.key([*place[:2], carry], DOWN, False))
            yield quantised(self.key(place, DOWN, True))
            if level < self.count - 1:  # as upstream, no retreat after the last block
                yield quantised(self.key(place + [0, 0, 0.06], DOWN, True))
            top_xy = np.asarray(block.pose.p[:2], dtype=float)
