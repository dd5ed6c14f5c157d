"""place_wine_at_rack_location (seen).

Task description:
    A wine rack with three slots side by side (left, middle, right, as seen from the robot)
    stands on the table; each slot is a pair of U-shaped cradles in which a bottle lies along
    the rack's depth. A wine bottle lies on its side on the table in front of the rack. The
    robot picks the bottle up from above, turns it to lie along the slots, lays it in the named
    slot (neck to the front or to the back) and lets go of it.

Randomisations:
    - the slot (variation 0: left, 1: middle, 2: right) when variations are sampled;
    - rack centre x in [0.30, 0.38] m, y in [-0.06, 0.06] m, yaw in [-45, 45] degrees (RLBench's
      base_rotation_bounds);
    - bottle centre x in [0.02, 0.12] m, y in [-0.15, 0.15] m, lying across the table (its
      axis along y) with yaw in [-30, 30] degrees and the neck pointing to either side.

Success conditions:
    The bottle lies in the named slot (its body centre between that slot's cradles, below
    their tops, its axis within 30 degrees of the slot's) AND the gripper holds nothing.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, frame_quat, needs_turn, turn_gripper, wrist_friendly

POSITIONS = ("left", "middle", "right")
SLOT_Y = (0.11, 0.0, -0.11)  # slot centres along the rack's y (left = +y, seen from the robot)
BODY_HALF = (0.10, 0.025)  # bottle body: half length, half width (square collision, round look)
NECK_HALF = (0.045, 0.011)
CRADLE_X = 0.065  # the cradles stand at +-CRADLE_X along the slot
CRADLE_FLOOR = 0.015  # height of a cradle's floor
POST_H = 0.06  # height of a cradle's posts above the table
GAP = 0.035  # half gap between a cradle's posts
POST_T = 0.0075  # half thickness of a post along y
GRIP_BELOW_TOP = 0.012  # the TCP is this far below the bottle's top when grasping


class PlaceWineAtRackLocation(Task):
    name = "place_wine_at_rack_location"
    max_control_steps = 92  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "seen"
    instruction = "stack the wine bottle to the left of the rack"
    # RLBench's variation 0 is the middle slot; ours (AGNOSTOS's instruction) is the left, so its
    # templates are filled in with "left"
    phrasings = (  # RLBench's variation-0 phrasings, AGNOSTOS's instruction first
        "stack the wine bottle to the left of the rack",
        "slide the bottle onto the left part of the rack",
        "put the wine on the left",
        "leave the wine on the left section of the shelf",
        "grasp the bottle and put it away on the left",
    )
    object_names = ("wine bottle", "left slot", "middle slot", "right slot")

    def load(self) -> None:
        wood = (0.55, 0.35, 0.18)
        ab = self.world.scene.create_articulation_builder()
        base = ab.create_link_builder()
        base.set_name("rack")
        # two rails join the cradles
        for sx in (-1, 1):
            add_box(base, [0.01, 0.17, 0.006], sapien.Pose([sx * CRADLE_X, 0, 0.006]), wood)
        links = {"rack": "wine rack"}
        for i, pos in enumerate(POSITIONS):
            slot = ab.create_link_builder(base)
            slot.set_name(f"{pos}_slot")
            slot.set_joint_name(f"{pos}_slot_joint")
            slot.set_joint_properties("fixed", [], sapien.Pose([0, SLOT_Y[i], 0]), sapien.Pose())
            for sx in (-1, 1):
                floor = sapien.Pose([sx * CRADLE_X, 0, CRADLE_FLOOR / 2])
                add_box(slot, [0.01, GAP + 2 * POST_T, CRADLE_FLOOR / 2], floor, wood, material=physical(1.0))
                for sy in (-1, 1):
                    post = sapien.Pose([sx * CRADLE_X, sy * (GAP + POST_T), POST_H / 2])
                    add_box(slot, [0.01, POST_T, POST_H / 2], post, wood)
            links[f"{pos}_slot"] = f"{pos} slot"
        self.rack = self.objects.articulation(ab, links, "wine rack")

        glass = look((0.05, 0.25, 0.10), roughness=0.2)
        bb = self.world.scene.create_actor_builder()
        mat = physical(1.5)
        bb.add_box_collision(half_size=[BODY_HALF[0], BODY_HALF[1], BODY_HALF[1]], material=mat, density=500.0)
        bb.add_cylinder_visual(radius=BODY_HALF[1] + 0.002, half_length=BODY_HALF[0], material=glass)
        neck = sapien.Pose([BODY_HALF[0] + NECK_HALF[0], 0, 0])
        neck_half = [NECK_HALF[0], NECK_HALF[1], NECK_HALF[1]]
        bb.add_box_collision(pose=neck, half_size=neck_half, material=mat, density=500.0)
        bb.add_cylinder_visual(pose=neck, radius=NECK_HALF[1], half_length=NECK_HALF[0], material=glass)
        label = sapien.Pose([-0.01, 0, 0])
        add_cylinder(bb, BODY_HALF[1] + 0.0025, 0.04, label, (0.92, 0.88, 0.75), axis="x", collide=False)
        cap = sapien.Pose([BODY_HALF[0] + 2 * NECK_HALF[0] - 0.01, 0, 0])
        add_cylinder(bb, NECK_HALF[1] + 0.002, 0.012, cap, (0.55, 0.05, 0.10), axis="x", collide=False)
        self.bottle = self.objects.actor(bb, "wine bottle")

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        variation = int(rng.integers(3))
        self.variation = variation if sample_variation else 0
        self.episode_instruction = f"stack the wine bottle to the {POSITIONS[self.variation]} of the rack"
        yaw = np.deg2rad(rng.uniform(-45.0, 45.0))
        self.rack_pose = yaw_pose(rng.uniform(0.30, 0.38), rng.uniform(-0.06, 0.06), TABLE_TOP_Z, yaw)
        self.rack.set_root_pose(self.rack_pose)
        neck_side = 1.0 if rng.integers(2) == 0 else -1.0
        bottle_yaw = neck_side * np.pi / 2 + np.deg2rad(rng.uniform(-30.0, 30.0))
        x, y = rng.uniform(0.02, 0.12), rng.uniform(-0.15, 0.15)
        self.bottle.set_pose(yaw_pose(x, y, TABLE_TOP_Z + BODY_HALF[1] + 0.001, bottle_yaw))
        body = self.bottle.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
        body.set_linear_velocity([0, 0, 0])
        body.set_angular_velocity([0, 0, 0])

    def slot_of_bottle(self) -> int | None:
        """The slot the bottle lies in, or None."""
        pose = self.rack_pose.inv() * self.bottle.pose
        local = np.asarray(pose.p, dtype=float)
        axis = pose.to_transformation_matrix()[:3, 0]
        if abs(local[0]) > CRADLE_X or local[2] > POST_H or abs(axis[0]) < np.cos(np.deg2rad(30.0)):
            return None
        for i, y in enumerate(SLOT_Y):
            if abs(local[1] - y) < GAP:
                return i
        return None

    def evaluate(self) -> bool:
        return self.slot_of_bottle() == self.variation and not self.grasped()

    @staticmethod
    def _down_quat(across) -> np.ndarray:
        down = np.array([0.0, 0.0, -1.0])
        return frame_quat(np.cross(across, down), across, down)

    def demonstration(self):
        pose = self.bottle.pose
        rot = pose.to_transformation_matrix()[:3, :3]
        axis = rot[:, 0] * np.array([1.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        # fingers close across the bottle; grasp the body a little towards the neck (balance)
        quat = self._down_quat(np.cross([0.0, 0.0, 1.0], axis))
        turn = needs_turn(quat)
        if turn:
            quat = turn_gripper(quat)
        top = np.asarray(pose.p, dtype=float) + axis * 0.02 + [0.0, 0.0, BODY_HALF[1]]
        grasp = top - [0.0, 0.0, GRIP_BELOW_TOP]
        yield self.key(grasp + [0.0, 0.0, 0.10], quat, True)
        yield self.key(grasp, quat, False)
        lift = grasp + [0.0, 0.0, 0.12]
        yield self.key(lift, quat, False)
        # lay it along the slot (the neck towards whichever end needs the smaller wrist turn):
        # the grasp point goes where the same point of a bottle centred in the slot would be
        slot_axis = self.rack_pose.to_transformation_matrix()[:3, 0]
        delta = np.arctan2(slot_axis[1], slot_axis[0]) - np.arctan2(axis[1], axis[0])
        delta = (delta + np.pi / 2) % np.pi - np.pi / 2
        spin = sapien.Pose(q=[np.cos(delta / 2), 0.0, 0.0, np.sin(delta / 2)])
        carry_q = wrist_friendly((spin * sapien.Pose(q=quat)).q)
        # where the bottle's axis ends up: it turns with the hand
        grasp_rot = sapien.Pose(q=quat).to_transformation_matrix()[:3, :3]
        carry_rot = sapien.Pose(q=carry_q).to_transformation_matrix()[:3, :3]
        new_axis = carry_rot @ grasp_rot.T @ axis
        centre = self.world_point(self.rack_pose, [0.0, SLOT_Y[self.variation], 0.0])
        place = centre + new_axis * 0.02
        place[2] = TABLE_TOP_Z + CRADLE_FLOOR + 2 * BODY_HALF[1] + 0.006 - GRIP_BELOW_TOP
        yield self.key(place + [0.0, 0.0, 0.10], carry_q, False)
        yield self.key(place, carry_q, True)
        yield self.key(place + [0.0, 0.0, 0.10], carry_q, True)
