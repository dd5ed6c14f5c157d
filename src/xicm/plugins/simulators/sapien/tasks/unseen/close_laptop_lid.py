"""close_laptop_lid (unseen, level 1).

Task description:
    An open laptop lies on the table facing the robot, its lid (screen) tilted back past the
    vertical and resting on its stiff hinge. The robot pushes the lid over from behind with its
    closed gripper until the lid falls shut onto the keyboard.

Randomisations:
    - laptop yaw in [-180, 180] degrees (RLBench's default base_rotation_bounds), centre x in
      [0.05, 0.17] m plus 0.10 m x max(0, -cos(yaw)) (a laptop facing away stands further back,
      its lid in reach), y in [-0.20, 0.20] m;
    - the lid's opening angle in [1.95, 2.20] rad (112 to 126 degrees; the hinge stops it there).

Success conditions:
    The lid has rotated (closed) by more than 1.79 rad from its opening angle at the start.
    Under simulator.scenes: rlbench, RLBench's JointCondition: the joint moved by more than that
    from its start angle in either direction (|change|): opening it further counts too where the
    hinge allows it.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, look, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, push_lid_shut

BASE_HALF = (0.105, 0.15, 0.009)  # half depth (x), width (y) and thickness of the base
LID_L, LID_T = 0.205, 0.008  # lid length (hinge to top edge) and thickness
HINGE_X = BASE_HALF[0] - 0.005  # hinge line: at the back of the base, on its top
SUCCESS_ANGLE = 1.79
PUSH_R = LID_L - 0.02  # the demonstrator pushes near the top edge, so the hand stays above the lid
Y_AXIS = [np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)]  # joint x axis -> +y: q > 0 lifts the lid


class CloseLaptopLid(Task):
    name = "close_laptop_lid"
    max_control_steps = 68  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "level1"
    instruction = "close laptop lid"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "close laptop lid",
        "close the laptop",
        "shut the laptop lid",
    )
    object_names = ("laptop", "laptop lid")

    def load(self) -> None:
        """Nothing to build before the lid's resting angle (its hinge stop) is known; see initialise()."""
        self.laptop = None

    def _build(self, stop: float, pose: sapien.Pose):
        shell = look((0.62, 0.63, 0.66), roughness=0.3, metallic=0.6)
        keys = (0.10, 0.10, 0.11)
        ab = self.world.scene.create_articulation_builder()
        base = ab.create_link_builder()
        base.set_name("base")
        hx, hy, hz = BASE_HALF
        add_box(base, [hx, hy, hz], sapien.Pose([0, 0, hz]), shell, density=1500.0)
        keyboard = sapien.Pose([0.025, 0, 2 * hz + 0.0005])
        add_box(base, [0.05, hy - 0.02, 0.0005], keyboard, keys, collide=False)
        add_box(base, [0.025, 0.04, 0.0005], sapien.Pose([-0.065, 0, 2 * hz + 0.0005]), keys, collide=False)  # touchpad

        lid = ab.create_link_builder(base)
        lid.set_name("lid")
        lid.set_joint_name("lid_hinge")
        hinge = sapien.Pose([HINGE_X, 0, 2 * hz], Y_AXIS)
        lid.set_joint_properties("revolute", [[0.0, stop]], hinge, sapien.Pose(q=Y_AXIS), friction=0.0, damping=0.05)
        # lid frame = base axes at the hinge; closed, the lid lies along -x on the keyboard
        add_box(lid, [LID_L / 2, hy, LID_T / 2], sapien.Pose([-LID_L / 2, 0, LID_T / 2]), shell, density=1200.0)
        screen = sapien.Pose([-LID_L / 2, 0, -0.0005])
        add_box(lid, [LID_L / 2 - 0.012, hy - 0.012, 0.0005], screen, look((0.05, 0.12, 0.30), roughness=0.1),
                collide=False)
        return self.objects.articulation(ab, {"base": "laptop", "lid": "laptop lid"}, "laptop", pose)

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        x = rng.uniform(0.05, 0.17)
        y = rng.uniform(-0.20, 0.20)
        yaw = np.deg2rad(rng.uniform(-180.0, 180.0))
        x += 0.10 * max(0.0, -np.cos(yaw))  # a laptop facing away moves back: its lid stays in reach
        self.start_angle = float(rng.uniform(1.95, 2.20))
        # the lid leans back against its hinge stop: it stays open until pushed past the vertical
        self.laptop = self._build(self.start_angle, yaw_pose(x, y, TABLE_TOP_Z, yaw))
        self.laptop.set_qpos(np.array([self.start_angle]))
        self.laptop.set_qvel(np.zeros(1))
        self.laptop.set_sleep_threshold(0.0)  # never freeze part-way: gravity always acts on it
        self.variation = 0
        self.episode_instruction = self.instruction

    def angle(self) -> float:
        """Opening angle of the lid (0 = shut)."""
        return float(self.laptop.get_qpos()[0])

    def evaluate(self) -> bool:
        return self.joint_moved(self.start_angle, self.angle(), SUCCESS_ANGLE, -1)

    def demonstration(self):
        root = self.laptop.get_root_pose()
        yield from push_lid_shut(root, (HINGE_X, 2 * BASE_HALF[2]), LID_T, self.angle(), PUSH_R, 0.05, 0.45)
