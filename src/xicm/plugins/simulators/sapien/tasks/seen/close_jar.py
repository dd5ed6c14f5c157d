"""close_jar (seen).

Task description:
    Two coloured glass jars stand open on the table and a screw-on jar lid lies flat beside
    them. The robot picks the lid up from above, sets it on the mouth of the jar of the named
    colour and lets go of it.

Randomisations:
    - when variations are sampled: the colour of the target jar (variation = its index in
      eight colours; variation 0 is red) and a different colour for the distractor jar, and
      which of the two jars is listed first; without sampling the jars are red (target) and
      green;
    - the two jars and the lid anywhere in x in [0.02, 0.34] m, y in [-0.26, 0.26] m, at
      least 0.13 m apart (centre to centre), each with a random yaw.

Success conditions:
    The lid rests on the target jar (its centre within 2 cm of the jar's axis, its underside
    within 1.5 cm of the jar's mouth, tilted by less than 20 degrees) AND nothing is grasped.
"""

from __future__ import annotations

import numpy as np
import sapien


from ...objects import add_box, add_cylinder, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, quantised

PALETTE = ("red", "green", "blue", "yellow", "orange", "purple", "cyan", "white")
JAR_R, JAR_H = 0.035, 0.08  # jar body
NECK_R, NECK_H = 0.027, 0.012  # the threaded neck on top of the body
JAR_TOP = JAR_H + NECK_H  # height of the jar's mouth above the table
LID_R, LID_H = 0.029, 0.025  # the lid: 5.8 cm across, lifted by its rim
SPAWN_X, SPAWN_Y, MIN_GAP = (0.02, 0.34), (-0.26, 0.26), 0.13


def sample_spots(rng: np.random.Generator, count: int, xs, ys, gap: float) -> list[np.ndarray]:
    spots: list[np.ndarray] = []
    while len(spots) < count:
        p = np.array([rng.uniform(*xs), rng.uniform(*ys)])
        if all(np.linalg.norm(p - q) >= gap for q in spots):
            spots.append(p)
    return spots


class CloseJar(Task):
    name = "close_jar"
    max_control_steps = 94  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "seen"
    instruction = "close the red jar"
    phrasings = (  # RLBench's variation-0 phrasings, AGNOSTOS's instruction first
        "close the red jar",
        "screw on the red jar lid",
        "grasping the lid, lift it from the table and use it to seal the red jar",
        "pick up the lid from the table and put it on the red jar",
    )
    object_names = ("red jar", "green jar", "jar lid")

    def load(self) -> None:
        """The lid now; the jars in initialise(), once their colours are known."""
        b = self.world.scene.create_actor_builder()
        metal = look((0.72, 0.72, 0.74), roughness=0.3, metallic=0.8)
        grip = physical(1.5)
        add_cylinder(b, LID_R, LID_H / 2, color=metal, material=grip, density=700.0)
        for k in range(12):  # ribs around the rim (visual only)
            a = 2 * np.pi * k / 12
            rib = sapien.Pose([LID_R * np.cos(a), LID_R * np.sin(a), 0], [np.cos(a / 2), 0, 0, np.sin(a / 2)])
            add_box(b, [0.0015, 0.003, LID_H / 2 - 0.002], rib, (0.55, 0.55, 0.57), collide=False)
        self.lid = self.objects.actor(b, "jar lid")
        self.jars: list[sapien.Entity] = []

    def _build_jar(self, colour: str, pose: sapien.Pose) -> sapien.Entity:
        b = self.world.scene.create_actor_builder()
        glass = look(colour, roughness=0.15)
        mat = physical(1.0)
        add_cylinder(b, JAR_R, JAR_H / 2, sapien.Pose([0, 0, JAR_H / 2]), glass, material=mat, density=1500.0)
        neck = sapien.Pose([0, 0, JAR_H + NECK_H / 2])
        add_cylinder(b, NECK_R, NECK_H / 2, neck, glass, material=mat, density=1500.0)
        label = sapien.Pose([0, 0, JAR_H * 0.45])
        add_cylinder(b, JAR_R + 0.0008, 0.018, label, (0.93, 0.91, 0.84), collide=False)
        return self.objects.actor(b, f"{colour} jar", pose=pose)

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        target = int(rng.integers(len(PALETTE)))
        distractor = int(rng.choice([i for i in range(len(PALETTE)) if i != target]))
        target_first = bool(rng.integers(2))
        if not sample_variation:
            target, distractor, target_first = 0, 1, True
        spots = sample_spots(rng, 3, SPAWN_X, SPAWN_Y, MIN_GAP)
        yaws = rng.uniform(-np.pi, np.pi, 3)
        colours = [PALETTE[target], PALETTE[distractor]]
        order = [0, 1] if target_first else [1, 0]
        self.jars = [None, None]  # type: ignore[list-item]
        for slot, k in enumerate(order):
            self.jars[k] = self._build_jar(colours[k], yaw_pose(*spots[slot], TABLE_TOP_Z, yaws[slot]))
        self.target_jar = self.jars[0]
        self.lid.set_pose(yaw_pose(*spots[2], TABLE_TOP_Z + LID_H / 2, yaws[2]))
        self.variation = target
        self.colour = PALETTE[target]
        self.episode_instruction = f"close the {self.colour} jar"
        self.episode_object_names = [f"{colours[k]} jar" for k in order] + ["jar lid"]

    def lid_on(self, jar: sapien.Entity) -> bool:
        lid, base = self.lid.pose, jar.pose
        up = lid.to_transformation_matrix()[:3, 2]
        tilt = np.degrees(np.arccos(np.clip(abs(up[2]), -1.0, 1.0)))
        off = np.linalg.norm(np.asarray(lid.p[:2]) - np.asarray(base.p[:2]))
        gap = (lid.p[2] - LID_H / 2) - (base.p[2] + JAR_TOP)
        return bool(off < 0.02 and -0.01 < gap < 0.015 and tilt < 20.0)

    def evaluate(self) -> bool:
        return self.lid_on(self.target_jar) and not self.grasped()

    def demonstration(self):
        lid = np.asarray(self.lid.pose.p, dtype=float)
        grasp = lid + [0.0, 0.0, LID_H / 2 - 0.012]  # fingertips 3.5 mm above the table
        yield quantised(self.key(grasp + [0, 0, 0.10], gripper_open=True))
        yield quantised(self.key(grasp, gripper_open=False))
        # where the lid sits in the hand now decides where the hand goes
        tcp = np.asarray(self.world.robot.tcp_pose().p, dtype=float)
        in_hand = tcp - np.asarray(self.lid.pose.p, dtype=float)
        mouth = np.asarray(self.target_jar.pose.p, dtype=float) + [0.0, 0.0, JAR_TOP]
        place = mouth + [0.0, 0.0, LID_H / 2 + 0.007] + in_hand  # lid's underside 7 mm above the mouth
        carry = max(place[2], grasp[2]) + 0.08
        yield quantised(self.key([*grasp[:2], carry], gripper_open=False))
        yield quantised(self.key([*place[:2], carry], gripper_open=False))
        yield quantised(self.key(place, gripper_open=True))
        yield quantised(self.key(place + [0, 0, 0.08], gripper_open=True))
