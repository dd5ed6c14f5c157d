"""toilet_seat_down (unseen, level 1).

Task description:
    A toilet stands on the table facing the robot: a white bowl on a pedestal with a low
    cistern behind it. The ring-shaped seat is raised, tilted back past the vertical and resting
    on its hinge stop. The robot pushes the seat over from behind with its closed gripper until
    it falls down onto the bowl.

Randomisations:
    - toilet centre x in [0.05, 0.15] m, y in [-0.20, 0.20] m, yaw in [-45, 45] degrees (RLBench's
      base_rotation_bounds);
    - the raised seat's angle in [1.80, 1.92] rad (103 to 110 degrees; the hinge stops it there).

Success conditions:
    The seat has been lowered by more than 1.7 rad from its angle at the start.
    Under simulator.scenes: rlbench, RLBench's JointCondition: the joint moved by more than that
    from its start angle in either direction (|change|): opening it further counts too where the
    hinge allows it.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, look, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, push_lid_shut

RIM_Z = 0.20  # height of the bowl's rim
HINGE = (0.06, RIM_Z + 0.003)  # hinge line (local x, z) at the back of the rim
SEAT_L, SEAT_HW, SEAT_T = 0.20, 0.085, 0.012  # seat length (hinge to front), half width, thickness
CISTERN = (0.115, 0.19, 0.30)  # cistern front x, back x and top z: below the raised seat's top
SUCCESS_ANGLE = 1.7
PUSH_R = 0.175  # the demonstrator pushes near the seat's front edge (then at the top)
Y_AXIS = [np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)]  # joint x axis -> +y: q > 0 raises the seat


class ToiletSeatDown(Task):
    name = "toilet_seat_down"
    max_control_steps = 62  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "level1"
    instruction = "toilet seat down"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "toilet seat down",
        "put the toilet seat down",
        "grasping the top of the lid, close the toilet seat",
        "put the toilet lid down",
        "leave the toilet seat down",
        "close the lid on the toilet",
        "lower the toilet seat",
        "grip the edge of the toilet lid and lower it flat on the toilet seat",
    )
    object_names = ("toilet", "toilet seat")

    def load(self) -> None:
        """Nothing to build before the seat's resting angle (its hinge stop) is known; see initialise()."""
        self.toilet = None

    def _build(self, stop: float, pose: sapien.Pose):
        porcelain = look((0.96, 0.96, 0.95), roughness=0.15)
        ab = self.world.scene.create_articulation_builder()
        body = ab.create_link_builder()
        body.set_name("toilet")
        add_box(body, [0.12, 0.06, 0.06], sapien.Pose([0.06, 0, 0.06]), porcelain)  # pedestal
        bowl_x = -0.03
        add_cylinder(body, 0.10, 0.04, sapien.Pose([bowl_x, 0, RIM_Z - 0.04]), porcelain)  # bowl
        add_box(body, [0.045, 0.085, 0.04], sapien.Pose([0.03, 0, RIM_Z - 0.04]), porcelain)  # bowl back
        water = sapien.Pose([bowl_x - 0.005, 0, RIM_Z + 0.0005])
        add_cylinder(body, 0.07, 0.0005, water, look((0.55, 0.75, 0.85), roughness=0.05), collide=False)
        front, back, top = CISTERN
        cistern = sapien.Pose([(front + back) / 2, 0, (top + 0.12) / 2])
        add_box(body, [(back - front) / 2, 0.10, (top - 0.12) / 2], cistern, porcelain)
        add_box(body, [(back - front) / 2 + 0.006, 0.106, 0.006], sapien.Pose([(front + back) / 2, 0, top + 0.006]),
                porcelain)  # cistern lid
        add_cylinder(body, 0.012, 0.003, sapien.Pose([(front + back) / 2, 0, top + 0.015]), (0.7, 0.7, 0.72),
                     collide=False)  # flush button
        for side in (-1, 1):  # hinge blocks
            add_cylinder(body, 0.008, 0.01, sapien.Pose([HINGE[0], side * 0.06, HINGE[1]]), (0.8, 0.8, 0.8), axis="y",
                         collide=False)

        seat = ab.create_link_builder(body)
        seat.set_name("seat")
        seat.set_joint_name("seat_hinge")
        hinge = sapien.Pose([HINGE[0], 0, HINGE[1]], Y_AXIS)
        seat.set_joint_properties("revolute", [[0.0, stop]], hinge, sapien.Pose(q=Y_AXIS), friction=0.0, damping=0.05)
        # seat frame = body axes at the hinge; lowered, the seat lies along -x on the rim.
        # One flat box collides; the ring is drawn as four bars around a dark opening.
        z = SEAT_T / 2
        seat.add_box_collision(sapien.Pose([-SEAT_L / 2, 0, z]), [SEAT_L / 2, SEAT_HW, z], density=800.0)
        ivory = look((0.93, 0.91, 0.84), roughness=0.3)
        add_box(seat, [SEAT_L / 2, 0.025, z], sapien.Pose([-SEAT_L / 2, SEAT_HW - 0.025, z]), ivory, collide=False)
        add_box(seat, [SEAT_L / 2, 0.025, z], sapien.Pose([-SEAT_L / 2, -SEAT_HW + 0.025, z]), ivory, collide=False)
        add_box(seat, [0.025, SEAT_HW, z], sapien.Pose([-SEAT_L + 0.025, 0, z]), ivory, collide=False)
        add_box(seat, [0.03, SEAT_HW, z], sapien.Pose([-0.03, 0, z]), ivory, collide=False)
        add_box(seat, [SEAT_L / 2 - 0.05, SEAT_HW - 0.05, 0.001], sapien.Pose([-SEAT_L / 2 - 0.005, 0, 0.002]),
                (0.45, 0.55, 0.6), collide=False)  # the opening (the water seen through it)
        return self.objects.articulation(ab, {"toilet": "toilet", "seat": "toilet seat"}, "toilet", pose)

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        x = rng.uniform(0.05, 0.15)
        y = rng.uniform(-0.20, 0.20)
        yaw = np.deg2rad(rng.uniform(-45.0, 45.0))
        self.start_angle = float(rng.uniform(1.80, 1.92))
        # the raised seat leans back against its hinge stop until pushed past the vertical
        self.toilet = self._build(self.start_angle, yaw_pose(x, y, TABLE_TOP_Z, yaw))
        self.toilet.set_qpos(np.array([self.start_angle]))
        self.toilet.set_qvel(np.zeros(1))
        self.toilet.set_sleep_threshold(0.0)  # never freeze part-way: gravity always acts on it
        self.toilet.get_active_joints()[0].set_friction(0.0)  # a loose hinge (PhysX's default holds it)
        self.variation = 0
        self.episode_instruction = self.instruction

    def angle(self) -> float:
        """How far the seat is raised (0 = down on the bowl)."""
        return float(self.toilet.get_qpos()[0])

    def evaluate(self) -> bool:
        return self.joint_moved(self.start_angle, self.angle(), SUCCESS_ANGLE, -1)

    def demonstration(self):
        root = self.toilet.get_root_pose()
        yield from push_lid_shut(root, HINGE, SEAT_T, self.angle(), PUSH_R, 0.04, 0.40)
