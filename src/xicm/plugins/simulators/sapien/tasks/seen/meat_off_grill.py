"""meat_off_grill (seen).

Task description:
    A barbecue grill stands on the table with a piece of chicken (a drumstick) and a steak
    lying on its grate. The robot picks up the named piece of meat, puts it down on the table
    beside the grill's side nearest the robot and lets go of it.

Randomisations:
    - the meat to take off (variation 0: chicken, 1: steak) when variations are sampled;
    - grill centre x in [0.26, 0.36] m, y in [-0.12, 0.12] m, yaw in [-180, 180] degrees (RLBench's
      default base_rotation_bounds);
    - which half of the grate each piece lies on, each piece's offset along the grill's depth
      in [-0.03, 0.03] m and its yaw in [-30, 30] degrees relative to the grill.

Success conditions:
    The named meat rests on the table (not on the grill) with its centre outside the grill's
    footprint and within 0.25 m of it, AND the gripper holds nothing.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, frame_quat, needs_turn, turn_gripper

MEATS = ("chicken", "steak")
GRILL_HALF = (0.12, 0.17)  # half depth (x) and half width (y) of the grill
GRILL_H = 0.10  # height of the grate above the table
STEAK_HALF = (0.045, 0.027, 0.015)
CHICKEN_R, CHICKEN_HALF = 0.021, 0.035  # drumstick body: radius and half length
SIDE_Y = 0.075  # distance of each piece from the grill's centre line
ZONE = 0.25  # how far beside the grill the meat may lie
DROP_OUT = 0.11  # the demonstrator puts the meat this far in front of the grill's front edge


class MeatOffGrill(Task):
    name = "meat_off_grill"
    max_control_steps = 88  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "seen"
    instruction = "take the chicken off the grill"
    phrasings = (  # RLBench's variation-0 phrasings, AGNOSTOS's instruction first
        "take the chicken off the grill",
        "pick up the chicken and place it next to the grill",
        "remove the chicken from the grill and set it down to the side",
    )
    object_names = ("chicken", "steak", "grill")

    def load(self) -> None:
        body = (0.12, 0.12, 0.13)
        metal = (0.55, 0.55, 0.58)
        ab = self.world.scene.create_articulation_builder()
        grill = ab.create_link_builder()
        grill.set_name("grill")
        hx, hy = GRILL_HALF
        add_box(grill, [hx, hy, GRILL_H / 2 - 0.005], sapien.Pose([0, 0, GRILL_H / 2 - 0.005]), body)
        add_box(grill, [hx, hy, 0.005], sapien.Pose([0, 0, GRILL_H - 0.005]), metal, material=physical(0.8))
        for k in range(-6, 7):  # grate bars (visual only, flush with the top)
            add_cylinder(grill, 0.003, hy - 0.01, sapien.Pose([k * 0.018, 0, GRILL_H]), (0.2, 0.2, 0.2), axis="y",
                         collide=False)
        for side in (-1, 1):  # side handles
            add_box(grill, [0.03, 0.006, 0.006], sapien.Pose([0, side * (hy + 0.02), GRILL_H - 0.02]), metal,
                    collide=False)
        self.grill = self.objects.articulation(ab, {"grill": "grill"}, "grill")

        grip = physical(1.5)
        # chicken: a drumstick, meaty body (box collision under a rounded look) and a bone
        cb = self.world.scene.create_actor_builder()
        meat_col = look((0.80, 0.55, 0.25), roughness=0.7)
        half = [CHICKEN_HALF + CHICKEN_R * 0.6, CHICKEN_R, CHICKEN_R]
        cb.add_box_collision(half_size=half, material=grip, density=700.0)
        cb.add_capsule_visual(radius=CHICKEN_R, half_length=CHICKEN_HALF, material=meat_col)
        bone = sapien.Pose([-(CHICKEN_HALF + CHICKEN_R + 0.02), 0, 0])
        add_cylinder(cb, 0.007, 0.025, bone, (0.95, 0.93, 0.85), axis="x", collide=False)
        cb.add_sphere_visual(pose=sapien.Pose([-(CHICKEN_HALF + CHICKEN_R + 0.045), 0, 0]), radius=0.011,
                             material=look((0.95, 0.93, 0.85)))
        self.chicken = self.objects.actor(cb, "chicken")

        sb = self.world.scene.create_actor_builder()
        sb.add_box_collision(half_size=STEAK_HALF, material=grip, density=900.0)
        sb.add_box_visual(half_size=STEAK_HALF, material=look((0.55, 0.12, 0.10), roughness=0.8))
        fat = sapien.Pose([0, STEAK_HALF[1] - 0.004, 0.0005])
        sb.add_box_visual(pose=fat, half_size=[STEAK_HALF[0] - 0.004, 0.0045, STEAK_HALF[2]],
                          material=look((0.95, 0.90, 0.80)))
        self.steak = self.objects.actor(sb, "steak")
        self.meats = [self.chicken, self.steak]
        self.heights = [CHICKEN_R, STEAK_HALF[2]]  # half height of each piece

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        variation = int(rng.integers(2))
        self.variation = variation if sample_variation else 0
        self.episode_instruction = f"take the {MEATS[self.variation]} off the grill"
        x = rng.uniform(0.26, 0.36)
        y = rng.uniform(-0.12, 0.12)
        yaw = np.deg2rad(rng.uniform(-180.0, 180.0))
        self.grill_pose = yaw_pose(x, y, TABLE_TOP_Z, yaw)
        self.grill.set_root_pose(self.grill_pose)
        sides = (1, -1) if rng.integers(2) == 0 else (-1, 1)
        for meat, side, half_h in zip(self.meats, sides, self.heights):
            local = np.array([rng.uniform(-0.03, 0.03), side * SIDE_Y, GRILL_H + half_h + 0.001])
            meat_yaw = yaw + np.deg2rad(rng.uniform(-30.0, 30.0))
            p = self.world_point(self.grill_pose, local)
            meat.set_pose(yaw_pose(p[0], p[1], p[2], meat_yaw))
            body = meat.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
            body.set_linear_velocity([0, 0, 0])
            body.set_angular_velocity([0, 0, 0])

    def _local_xy(self, p) -> np.ndarray:
        return np.asarray((self.grill_pose.inv() * sapien.Pose(p)).p, dtype=float)[:2]

    def off_grill(self, index: int) -> bool:
        """Whether meat `index` rests on the table beside the grill."""
        p = np.asarray(self.meats[index].pose.p, dtype=float)
        if p[2] > TABLE_TOP_Z + 0.04:
            return False
        local = np.abs(self._local_xy(p))
        outside = np.maximum(local - np.asarray(GRILL_HALF), 0.0)
        return bool(np.any(outside > 0) and np.linalg.norm(outside) < ZONE)

    def evaluate(self) -> bool:
        return self.off_grill(self.variation) and not self.grasped()

    def _grasp_quat(self, meat: sapien.Entity) -> np.ndarray:
        across = meat.pose.to_transformation_matrix()[:3, 1]  # fingers close across the piece
        across = across - across[2] * np.array([0.0, 0.0, 1.0])
        across /= np.linalg.norm(across)
        down = np.array([0.0, 0.0, -1.0])
        return frame_quat(np.cross(across, down), across, down)

    def demonstration(self):
        meat = self.meats[self.variation]
        half_h = self.heights[self.variation]
        quat = self._grasp_quat(meat)
        if needs_turn(quat):
            quat = turn_gripper(quat)
        centre = np.asarray(meat.pose.p, dtype=float)
        grasp = centre + [0.0, 0.0, half_h - 0.012]  # pads around the upper part of the piece
        yield self.key(grasp + [0.0, 0.0, 0.10], quat, True)
        yield self.key(grasp, quat, False)
        yield self.key(grasp + [0.0, 0.0, 0.10], quat, False)
        # down on the table beside the grill's side nearest the robot, level with the piece
        local = self._local_xy(centre)
        hx, hy = GRILL_HALF
        sides = (
            np.array([-hx - DROP_OUT, local[1], 0.0]),
            np.array([hx + DROP_OUT, local[1], 0.0]),
            np.array([local[0], -hy - DROP_OUT, 0.0]),
            np.array([local[0], hy + DROP_OUT, 0.0]),
        )
        drops = [self.world_point(self.grill_pose, p) for p in sides]
        robot_xy = self.world.robot.base_pose.p[:2]
        drop = min(drops, key=lambda w: float(np.hypot(w[0] - robot_xy[0], w[1])))
        drop[2] = TABLE_TOP_Z + 2 * half_h - 0.012 + 0.008
        yield self.key(drop + [0.0, 0.0, 0.10], quat, False)
        yield self.key(drop, quat, True)
        yield self.key(drop + [0.0, 0.0, 0.10], quat, True)
