"""put_money_in_safe (seen).

Task description:
    A steel safe with three open shelves (bottom, middle, top) and its door swung open stands
    on the table facing the robot, and a stack of banknotes lies on the table in front of it.
    The robot picks the money up by its near end (the gripper pointing forward and 45 degrees
    down), slides it into the safe on the named shelf and lets go of it.

Randomisations:
    - the shelf (variation 0: bottom, 1: middle, 2: top) when variations are sampled;
    - safe yaw in [-45, 45] degrees (the 90-degree span of RLBench's base_rotation_bounds,
      centred on the door facing the robot), centre x in [0.54, 0.60] m, y in [-0.15, 0.15] m
      shifted by 0.12 m x yaw / 45 degrees (keeps a turned safe's door within reach);
    - money centre, in the safe's frame: 0.08 to 0.12 m in front of the safe, -0.08 to 0.08 m
      sideways, yaw in [-20, 20] degrees relative to the safe.

Success conditions:
    The money lies on the named shelf (its centre inside that compartment, resting on the
    shelf floor) AND the gripper holds nothing.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, frame_quat, needs_turn, turn_gripper

SHELVES = ("bottom", "middle", "top")
DEPTH, WIDTH = 0.20, 0.30  # outer size of the safe
WALL = 0.012
PLINTH = 0.02  # the bottom shelf's floor height
SLOT = 0.11  # floor-to-floor height of a compartment
HEIGHT = PLINTH + 3 * SLOT + WALL
MONEY_HALF = (0.07, 0.025, 0.0175)  # long axis x, across y, thickness z
GRIP_BACK = 0.035  # the fingers hold the money this far from its near end
PITCH = np.deg2rad(45.0)  # the gripper points forward and 45 degrees down
INSIDE = 0.03  # how far past the safe's front the TCP goes to put the money down



def _floor_z(index: int) -> float:
    """Height above the safe's base of the floor of shelf `index` (0 = bottom)."""
    return PLINTH + index * SLOT


class PutMoneyInSafe(Task):
    name = "put_money_in_safe"
    max_control_steps = 124  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "seen"
    instruction = "put the money away in the safe on the bottom shelf"
    phrasings = (  # RLBench's variation-0 phrasings, AGNOSTOS's instruction first
        "put the money away in the safe on the bottom shelf",
        "leave the money on the bottom shelf on the safe",
        "place the stack of bank notes on the bottom shelf of the safe",
    )
    object_names = ("money", "safe", "bottom shelf", "middle shelf", "top shelf")

    def load(self) -> None:
        steel = (0.30, 0.32, 0.35)
        inner = (0.45, 0.46, 0.48)
        ab = self.world.scene.create_articulation_builder()
        body = ab.create_link_builder()
        body.set_name("safe")
        hx, hy = DEPTH / 2, WIDTH / 2
        add_box(body, [hx, hy, (PLINTH - WALL) / 2], sapien.Pose([0, 0, (PLINTH - WALL) / 2]), steel)  # base
        add_box(body, [hx, hy, WALL / 2], sapien.Pose([0, 0, HEIGHT - WALL / 2]), steel)  # roof
        for side in (-1, 1):
            add_box(body, [hx, WALL / 2, HEIGHT / 2], sapien.Pose([0, side * (hy - WALL / 2), HEIGHT / 2]), steel)
        add_box(body, [WALL / 2, hy, HEIGHT / 2], sapien.Pose([hx - WALL / 2, 0, HEIGHT / 2]), steel)  # back
        # the open door, swung fully open along the right-hand wall (visual only) with its dial
        door = sapien.Pose([-hx - 0.10, -hy - 0.012, HEIGHT / 2])
        add_box(body, [0.10, 0.012, HEIGHT / 2 - 0.005], door, steel, collide=False)
        dial = sapien.Pose([-hx - 0.10, -hy - 0.028, HEIGHT * 0.55])
        add_cylinder(body, 0.025, 0.006, dial, (0.75, 0.75, 0.78), axis="y", collide=False)
        links = {"safe": "safe"}
        for i, shelf in enumerate(SHELVES):
            link = ab.create_link_builder(body)
            link.set_name(f"{shelf}_shelf")
            link.set_joint_name(f"{shelf}_shelf_joint")
            link.set_joint_properties("fixed", [], sapien.Pose([0, 0, _floor_z(i) - WALL / 2]), sapien.Pose())
            add_box(link, [hx - WALL / 2, hy - WALL, WALL / 2], sapien.Pose([-WALL / 2, 0, 0]), inner,
                    material=physical(1.0))
            links[f"{shelf}_shelf"] = f"{shelf} shelf"
        self.safe = self.objects.articulation(ab, links, "safe")

        mb = self.world.scene.create_actor_builder()
        mb.add_box_collision(half_size=MONEY_HALF, material=physical(1.5), density=500.0)
        mb.add_box_visual(half_size=MONEY_HALF, material=look((0.55, 0.72, 0.50), roughness=0.9))
        band = [0.012, MONEY_HALF[1] + 0.0005, MONEY_HALF[2] + 0.0005]  # a paper band round the notes
        mb.add_box_visual(half_size=band, material=look((0.90, 0.88, 0.75)))
        self.money = self.objects.actor(mb, "money")

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        variation = int(rng.integers(3))
        self.variation = variation if sample_variation else 0
        self.episode_instruction = f"put the money away in the safe on the {SHELVES[self.variation]} shelf"
        yaw = np.deg2rad(rng.uniform(-45.0, 45.0))
        # a turned safe moves to the side its door turns away from, so the door stays in reach
        y = rng.uniform(-0.15, 0.15) + 0.12 * yaw / (np.pi / 4)
        self.safe_pose = yaw_pose(rng.uniform(0.54, 0.60), y, TABLE_TOP_Z, yaw)
        self.safe.set_root_pose(self.safe_pose)
        local = [-DEPTH / 2 - rng.uniform(0.08, 0.12), rng.uniform(-0.08, 0.08), MONEY_HALF[2] + 0.001]
        mx, my, mz = self.world_point(self.safe_pose, local)
        money_yaw = yaw + np.deg2rad(rng.uniform(-20.0, 20.0))
        self.money.set_pose(yaw_pose(mx, my, mz, money_yaw))
        body = self.money.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
        body.set_linear_velocity([0, 0, 0])
        body.set_angular_velocity([0, 0, 0])

    def shelf_of_money(self) -> int | None:
        """The shelf the money rests on (its centre inside that compartment), or None."""
        local = np.asarray((self.safe_pose.inv() * self.money.pose).p, dtype=float)
        hx, hy = DEPTH / 2, WIDTH / 2
        if not (-hx < local[0] < hx - WALL and abs(local[1]) < hy - WALL):
            return None
        for i in range(3):
            if 0.0 < local[2] - _floor_z(i) < MONEY_HALF[2] + 0.02:
                return i
        return None

    def evaluate(self) -> bool:
        return self.shelf_of_money() == self.variation and not self.grasped()

    def demonstration(self):
        rot = self.money.pose.to_transformation_matrix()[:3, :3]
        along = rot[:, 0] * np.array([1.0, 1.0, 0.0])
        along /= np.linalg.norm(along)
        if along[0] < 0:  # hold the end nearer the robot, pointing the money away from it
            along = -along
        across = np.cross([0.0, 0.0, 1.0], along)
        approach = along * np.cos(PITCH) + np.array([0.0, 0.0, -np.sin(PITCH)])
        quat = frame_quat(np.cross(across, approach), across, approach)
        turn = needs_turn(quat)
        if turn:
            quat = turn_gripper(quat)
        centre = np.asarray(self.money.pose.p, dtype=float)
        # TCP a little above the money's mid-plane, so the pads stay clear of the table
        grasp = centre - along * (MONEY_HALF[0] - GRIP_BACK) + [0.0, 0.0, 0.008]
        yield self.key(grasp - approach * 0.08, quat, True)
        yield self.key(grasp, quat, False)
        yield self.key(grasp + [0.0, 0.0, 0.06], quat, False)

        # turn about the vertical so that the money points straight into the safe
        safe_rot = self.safe_pose.to_transformation_matrix()[:3, :3]
        into = safe_rot[:, 0]
        delta = np.arctan2(into[1], into[0]) - np.arctan2(along[1], along[0])
        spin = sapien.Pose(q=[np.cos(delta / 2), 0.0, 0.0, np.sin(delta / 2)])
        carry_q = np.asarray((spin * sapien.Pose(q=quat)).q, dtype=float)
        tcp_above_bottom = MONEY_HALF[2] + 0.008
        floor = _floor_z(self.variation)
        z = floor + tcp_above_bottom + 0.012
        front = -DEPTH / 2
        lead = MONEY_HALF[0] * 2 - GRIP_BACK  # how far the money reaches ahead of the TCP
        outside = self.world_point(self.safe_pose, [front - lead - 0.04, 0.0, z])
        inside = self.world_point(self.safe_pose, [front + INSIDE, 0.0, z])
        yield self.key(outside, carry_q, False)
        yield self.key(inside, carry_q, False)
        yield self.key(inside - [0.0, 0.0, 0.010], carry_q, True)
        yield self.key(outside, carry_q, True)
