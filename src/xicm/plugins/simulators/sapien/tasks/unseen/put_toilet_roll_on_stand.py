"""put_toilet_roll_on_stand (unseen, level 1).

Task description:
    A toilet roll (white paper wound on a brown cardboard core) stands upright on the table
    next to a toilet roll stand: a round wooden foot with a vertical post. The robot grips the
    roll's wall from above (one finger in the core's hole), lifts it over the post, lowers it
    so that the post goes into the core and lets go; the roll slides down onto the foot.

Randomisations:
    - roll centre x in [0.04, 0.20] m, y in [-0.25, 0.25] m, random yaw;
    - stand centre x in [0.26, 0.40] m, y in [-0.22, 0.22] m, random yaw, at least 0.17 m
      from the roll.

Success conditions:
    The roll is threaded on the post (its axis within its core radius of the post's axis,
    its centre below the post's top, upright within 25 degrees) AND nothing is grasped.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_cylinder, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, down_quat, quantised

R_OUT, R_IN, ROLL_H = 0.052, 0.028, 0.10  # the roll: outer and core radius, height
SEGMENTS = 16
FOOT_R, FOOT_H = 0.07, 0.015
POST_R, POST_TOP = 0.011, 0.11  # post radius; its top above the table
GRIP_DEPTH = 0.015  # the TCP this far below the roll's top when holding it
ENGAGE = 0.055  # release when the post is this far into the core
SPAWN_ROLL = ((0.04, 0.20), (-0.25, 0.25))
SPAWN_STAND = ((0.26, 0.40), (-0.22, 0.22))
MIN_GAP = 0.17


class PutToiletRollOnStand(Task):
    name = "put_toilet_roll_on_stand"
    max_control_steps = 94  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "level1"
    instruction = "put toilet roll on stand"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "put toilet roll on stand",
        "place the toilet roll on the stand",
        "slide the roll onto its holder",
    )
    object_names = ("toilet roll", "toilet roll stand")

    def load(self) -> None:
        ab = self.world.scene.create_articulation_builder()
        stand = ab.create_link_builder()
        stand.set_name("stand")
        wood = look((0.50, 0.32, 0.17), roughness=0.5)
        add_cylinder(stand, FOOT_R, FOOT_H / 2, sapien.Pose([0, 0, FOOT_H / 2]), wood, material=physical(0.8))
        post_half = (POST_TOP - FOOT_H) / 2
        chrome = look((0.75, 0.75, 0.78), roughness=0.25, metallic=0.8)
        add_cylinder(stand, POST_R, post_half, sapien.Pose([0, 0, FOOT_H + post_half]), chrome, material=physical(0.3))
        stand.add_sphere_visual(pose=sapien.Pose([0, 0, POST_TOP]), radius=POST_R * 1.3, material=chrome)
        self.stand = self.objects.articulation(ab, {"stand": "toilet roll stand"}, "toilet roll stand")

        # the roll: a hollow tube of flat wall segments (the collision) under a paper-white look
        b = self.world.scene.create_actor_builder()
        paper = look((0.97, 0.97, 0.95), roughness=0.9)
        core = look((0.60, 0.42, 0.25), roughness=0.9)
        mid, half_t = (R_OUT + R_IN) / 2, (R_OUT - R_IN) / 2
        half_w = R_OUT * np.tan(np.pi / SEGMENTS)
        for k in range(SEGMENTS):
            phi = 2 * np.pi * k / SEGMENTS
            pose = sapien.Pose([mid * np.cos(phi), mid * np.sin(phi), 0], [np.cos(phi / 2), 0, 0, np.sin(phi / 2)])
            b.add_box_collision(pose=pose, half_size=[half_t, half_w, ROLL_H / 2], material=physical(1.5),
                                density=300.0)
            b.add_box_visual(pose=pose, half_size=[half_t, half_w, ROLL_H / 2], material=paper)
            inner = sapien.Pose([(R_IN + 0.001) * np.cos(phi), (R_IN + 0.001) * np.sin(phi), 0], pose.q)
            b.add_box_visual(pose=inner, half_size=[0.0012, R_IN * np.tan(np.pi / SEGMENTS), ROLL_H / 2 + 0.0005],
                             material=core)
        self.roll = self.objects.actor(b, "toilet roll")

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        roll = np.array([rng.uniform(*SPAWN_ROLL[0]), rng.uniform(*SPAWN_ROLL[1])])
        while True:
            stand = np.array([rng.uniform(*SPAWN_STAND[0]), rng.uniform(*SPAWN_STAND[1])])
            if np.linalg.norm(stand - roll) >= MIN_GAP:
                break
        self.stand.set_root_pose(yaw_pose(*stand, TABLE_TOP_Z, rng.uniform(-np.pi, np.pi)))
        self.roll.set_pose(yaw_pose(*roll, TABLE_TOP_Z + ROLL_H / 2 + 0.001, rng.uniform(-np.pi, np.pi)))
        body = self.roll.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
        body.set_linear_velocity([0, 0, 0])
        body.set_angular_velocity([0, 0, 0])
        self.variation = 0
        self.episode_instruction = self.instruction

    def post_axis(self) -> np.ndarray:
        return np.asarray(self.stand.get_root_pose().p, dtype=float)

    def on_stand(self) -> bool:
        pose = self.roll.pose
        p = np.asarray(pose.p, dtype=float)
        up = pose.to_transformation_matrix()[:3, 2]
        base = self.post_axis()
        off = np.linalg.norm(p[:2] - base[:2])
        return bool(off < R_IN and p[2] < base[2] + POST_TOP and abs(up[2]) > np.cos(np.deg2rad(25.0)))

    def evaluate(self) -> bool:
        return self.on_stand() and not self.grasped()

    def demonstration(self):
        roll = np.asarray(self.roll.pose.p, dtype=float)
        # grip the wall with the fingers closing radially, on the side that will face the middle
        # of the table at the stand (the arm's reach is shorter towards the table's sides)
        side = -1.0 if self.post_axis()[1] > 0 else 1.0
        q = down_quat(0.0)  # fingers along world y
        top = roll[2] + ROLL_H / 2
        grasp = np.array([roll[0], roll[1] + side * (R_OUT + R_IN) / 2, top - GRIP_DEPTH])
        yield quantised(self.key(grasp + [0, 0, 0.10], q, True))
        yield quantised(self.key(grasp, q, False))
        # the roll centres its wall between the fingers: measure where it sits in the hand now
        tcp = np.asarray(self.world.robot.tcp_pose().p, dtype=float)
        in_hand = tcp - np.asarray(self.roll.pose.p, dtype=float)
        post = self.post_axis()
        # roll bottom 3 cm above the post's top while carrying it over
        carry = post[2] + POST_TOP + 0.03 + ROLL_H / 2 + in_hand[2]
        place = post + [in_hand[0], in_hand[1], 0.0]
        release = post[2] + POST_TOP - ENGAGE + ROLL_H / 2 + in_hand[2]
        yield quantised(self.key([grasp[0], grasp[1], carry], q, False))
        yield quantised(self.key([place[0], place[1], carry], q, False))
        yield quantised(self.key([place[0], place[1], release], q, True))
        yield quantised(self.key([place[0], place[1], carry], q, True))
