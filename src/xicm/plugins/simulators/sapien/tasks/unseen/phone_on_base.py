"""phone_on_base (unseen, level 1).

Task description:
    A cordless phone handset (dark grey, with a screen and a keypad) lies face up on the
    table next to its charging base, a low white dock with a handset-shaped cradle. The robot
    picks the handset up from above, turns it to line up with the cradle, lays it in the
    cradle and lets go of it.

Randomisations:
    - phone centre x in [0.04, 0.22] m, y in [-0.25, 0.25] m, yaw in [-180, 180] degrees;
    - base centre x in [0.30, 0.42] m, y in [-0.22, 0.22] m, yaw in [-180, 180] degrees, at
      least 0.20 m from the phone.

Success conditions:
    The phone lies in the base's cradle (its centre over the cradle, its underside within
    2.5 cm above the cradle floor, tilted by less than 20 degrees) AND nothing is grasped.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, down_quat, half_turn, quantised

PHONE_HALF = (0.08, 0.027, 0.012)  # handset half length, width, thickness
CRADLE_HALF = (0.095, 0.042)  # inner half size of the cradle
FLOOR = 0.015  # cradle floor above the table
RIM_H, RIM_T = 0.014, 0.008  # rim height above the floor, thickness
GRIP_DEPTH = 0.010  # the TCP this far below the phone's top when holding it
SPAWN_PHONE = ((0.04, 0.22), (-0.25, 0.25), 180.0)
SPAWN_BASE = ((0.30, 0.42), (-0.22, 0.22), 180.0)
MIN_GAP = 0.20



class PhoneOnBase(Task):
    name = "phone_on_base"
    max_control_steps = 110  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "level1"
    instruction = "put the phone on the base"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "put the phone on the base",
        "put the phone on the stand",
        "put the hone on the hub",
        "grasp the phone and put it on the base",
        "place the phone on the base",
        "put the phone back on the base",
    )
    object_names = ("phone", "phone base")

    def load(self) -> None:
        ab = self.world.scene.create_articulation_builder()
        base = ab.create_link_builder()
        base.set_name("base")
        white = look((0.92, 0.92, 0.90), roughness=0.4)
        cx, cy = CRADLE_HALF
        ox, oy = cx + RIM_T, cy + RIM_T
        add_box(base, [ox, oy, FLOOR / 2], sapien.Pose([0, 0, FLOOR / 2]), white, material=physical(1.0))
        rim_z = FLOOR + RIM_H / 2
        for s in (-1, 1):
            add_box(base, [ox, RIM_T / 2, RIM_H / 2], sapien.Pose([0, s * (cy + RIM_T / 2), rim_z]), white)
            add_box(base, [RIM_T / 2, cy, RIM_H / 2], sapien.Pose([s * (cx + RIM_T / 2), 0, rim_z]), white)
        pad = sapien.Pose([0, 0, FLOOR + 0.0005])  # dark charging pad and a green charge light
        add_box(base, [cx - 0.01, cy - 0.01, 0.0005], pad, (0.25, 0.25, 0.28), collide=False)
        add_cylinder(base, 0.004, 0.001, sapien.Pose([cx + RIM_T / 2, 0, FLOOR + RIM_H + 0.001]),
                     (0.1, 0.9, 0.2), collide=False)
        self.base = self.objects.articulation(ab, {"base": "phone base"}, "phone base")

        b = self.world.scene.create_actor_builder()
        add_box(b, PHONE_HALF, None, look((0.18, 0.18, 0.20), roughness=0.5), material=physical(1.5), density=600.0)
        hx, hy, hz = PHONE_HALF
        screen = sapien.Pose([hx * 0.45, 0, hz + 0.0005])
        add_box(b, [hx * 0.35, hy * 0.75, 0.0005], screen, look((0.10, 0.25, 0.35), roughness=0.15), collide=False)
        for i in range(4):  # keypad: 4 rows of 3 keys
            for j in range(3):
                key = sapien.Pose([-hx * 0.15 - i * 0.014, (j - 1) * 0.014, hz + 0.0007])
                add_box(b, [0.005, 0.0045, 0.0007], key, (0.75, 0.75, 0.78), collide=False)
        self.phone = self.objects.actor(b, "phone")

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        (px, py, pyaw), (bx, by, byaw) = SPAWN_PHONE, SPAWN_BASE
        phone = np.array([rng.uniform(*px), rng.uniform(*py)])
        while True:
            base = np.array([rng.uniform(*bx), rng.uniform(*by)])
            if np.linalg.norm(base - phone) >= MIN_GAP:
                break
        self.base.set_root_pose(yaw_pose(*base, TABLE_TOP_Z, np.deg2rad(rng.uniform(-byaw, byaw))))
        self.phone.set_pose(yaw_pose(*phone, TABLE_TOP_Z + PHONE_HALF[2] + 0.001, np.deg2rad(rng.uniform(-pyaw, pyaw))))
        body = self.phone.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
        body.set_linear_velocity([0, 0, 0])
        body.set_angular_velocity([0, 0, 0])
        self.variation = 0
        self.episode_instruction = self.instruction

    def on_base(self) -> bool:
        local = self.base.get_root_pose().inv() * self.phone.pose
        p = np.asarray(local.p, dtype=float)
        up = local.to_transformation_matrix()[:3, 2]
        bottom = p[2] - PHONE_HALF[2]
        inside = abs(p[0]) < CRADLE_HALF[0] and abs(p[1]) < CRADLE_HALF[1]
        return bool(inside and FLOOR - 0.005 < bottom < FLOOR + 0.025 and abs(up[2]) > np.cos(np.deg2rad(20.0)))

    def evaluate(self) -> bool:
        return self.on_base() and not self.grasped()

    def demonstration(self):
        pose = self.phone.pose
        centre = np.asarray(pose.p, dtype=float)
        axis = pose.to_transformation_matrix()[:3, 0]
        q = down_quat(half_turn(np.arctan2(axis[1], axis[0])))  # fingers close across the handset
        grasp = centre + [0.0, 0.0, PHONE_HALF[2] - GRIP_DEPTH]
        yield quantised(self.key(grasp + [0, 0, 0.10], q, True))
        yield quantised(self.key(grasp, q, False))
        lift = quantised(self.key(grasp + [0, 0, 0.10], q, False))
        yield lift
        # the phone's pose in the hand decides where the hand goes: put the phone where it
        # lies centred in the cradle, turned (by less than 90 degrees) to line up with it
        tcp = self.world.robot.tcp_pose()
        in_hand = self.phone.pose.inv() * tcp
        base = self.base.get_root_pose()
        phone_yaw = np.arctan2(*self.phone.pose.to_transformation_matrix()[1::-1, 0])
        base_yaw = np.arctan2(*base.to_transformation_matrix()[1::-1, 0])
        turn = half_turn(base_yaw - phone_yaw)
        # either end of the handset may go either way round: keep the wrist near its start turn
        hand_yaw = np.arctan2(*tcp.to_transformation_matrix()[1::-1, 0])
        if abs(hand_yaw + turn) > np.pi / 2:
            turn -= np.sign(hand_yaw + turn) * np.pi
        target = yaw_pose(*self.world_point(base, [0, 0, 0]), phone_yaw + turn)
        target.p = np.asarray(target.p) + [0, 0, FLOOR + PHONE_HALF[2] + 0.006]
        place = target * in_hand
        high = place.p + np.array([0, 0, 0.10])
        yield quantised(self.key([*place.p[:2], lift.position[2]], place.q, False))
        yield quantised(self.key(place.p, place.q, True))
        yield quantised(self.key(high, place.q, True))
