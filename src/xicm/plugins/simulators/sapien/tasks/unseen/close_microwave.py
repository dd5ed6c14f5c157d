"""close_microwave (unseen, level 1).

Task description:
    A microwave oven stands on the table facing the robot, its door (hinged on the left, seen
    from the robot) swung open. The robot pushes the door shut with its closed gripper.

Randomisations:
    - microwave centre x in [0.40, 0.50] m, y in [-0.20, 0.10] m, yaw in [-22.5, 22.5] degrees;
    - the door's opening angle in [80, 100] degrees.

Success conditions:
    The door has been closed by more than 40 degrees from its opening angle at the start.
    Under simulator.scenes: rlbench, RLBench's JointCondition: the joint moved by more than that
    from its start angle in either direction (|change|): opening it further counts too where the
    hinge allows it.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, door_push_pose, push_door_shut

DEPTH, WIDTH, HEIGHT = 0.30, 0.42, 0.25
PANEL = 0.10  # control panel width on the right-hand side of the front
DOOR_T = 0.02  # door thickness
DOOR_W = WIDTH - PANEL  # door width, hinge to free edge
DOOR_H = HEIGHT - 0.03
PUSH_R = 0.21  # distance from the hinge at which the demonstrator pushes
PUSH_Z = 0.21  # TCP height above the table while pushing: fingers on the door, hand above it
SUCCESS_ANGLE = np.deg2rad(40.0)


class CloseMicrowave(Task):
    name = "close_microwave"
    max_control_steps = 216  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "level1"
    instruction = "close microwave"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "close microwave",
        "shut the microwave",
        "close the microwave door",
        "push the microwave door shut",
    )
    object_names = ("microwave", "microwave door", "microwave door handle")

    def load(self) -> None:
        shell = (0.88, 0.88, 0.86)
        dark = (0.12, 0.12, 0.13)
        ab = self.world.scene.create_articulation_builder()
        body = ab.create_link_builder()
        body.set_name("body")
        hx, hy, wall = DEPTH / 2, WIDTH / 2, 0.015
        add_box(body, [hx, hy, wall / 2], sapien.Pose([0, 0, wall / 2]), shell)  # floor
        add_box(body, [hx, hy, wall / 2], sapien.Pose([0, 0, HEIGHT - wall / 2]), shell)  # roof
        add_box(body, [wall / 2, hy, HEIGHT / 2], sapien.Pose([hx - wall / 2, 0, HEIGHT / 2]), shell)  # back
        add_box(body, [hx, wall / 2, HEIGHT / 2], sapien.Pose([0, hy - wall / 2, HEIGHT / 2]), shell)  # left wall
        # control panel block on the right (-y) side, with a display and two knobs
        add_box(body, [hx, PANEL / 2, HEIGHT / 2], sapien.Pose([0, -hy + PANEL / 2, HEIGHT / 2]), shell)
        panel_y = -hy + PANEL / 2
        display = sapien.Pose([-hx - 0.001, panel_y, HEIGHT * 0.78])
        add_box(body, [0.001, 0.035, 0.018], display, (0.05, 0.25, 0.12), collide=False)
        for z in (0.45, 0.25):
            knob = sapien.Pose([-hx - 0.006, panel_y, HEIGHT * z])
            add_cylinder(body, 0.015, 0.006, knob, dark, axis="x", collide=False)

        door = ab.create_link_builder(body)
        door.set_name("door")
        door.set_joint_name("door_hinge")
        # joint x axis = world -z: q > 0 swings the free edge towards the robot
        hinge = sapien.Pose([-hx - DOOR_T / 2, hy - 0.005, HEIGHT / 2], [np.cos(np.pi / 4), 0, np.sin(np.pi / 4), 0])
        limits = [[0.0, np.deg2rad(120.0)]]
        door.set_joint_properties("revolute", limits, hinge, sapien.Pose(q=hinge.q), friction=0.0, damping=0.3)
        # door frame = body axes at the hinge; the door extends along -y
        add_box(door, [DOOR_T / 2, DOOR_W / 2, DOOR_H / 2], sapien.Pose([0, -DOOR_W / 2, 0]), shell, density=400.0)
        window = sapien.Pose([-DOOR_T / 2 - 0.001, -DOOR_W / 2 + 0.02, 0])
        add_box(door, [0.001, DOOR_W / 2 - 0.05, DOOR_H / 2 - 0.03], window, look(dark, roughness=0.2), collide=False)

        handle = ab.create_link_builder(door)
        handle.set_name("handle")
        handle.set_joint_name("handle_joint")
        handle.set_joint_properties("fixed", [], sapien.Pose([-DOOR_T / 2, -DOOR_W + 0.03, 0]), sapien.Pose())
        chrome = (0.6, 0.6, 0.62)
        add_cylinder(handle, 0.008, 0.07, sapien.Pose([-0.025, 0, 0]), chrome, material=physical(1.0), axis="z")
        for side in (-1, 1):
            add_box(handle, [0.0125, 0.006, 0.006], sapien.Pose([-0.0125, 0, side * 0.055]), chrome)
        self.microwave = self.objects.articulation(
            ab, {"body": "microwave", "door": "microwave door", "handle": "microwave door handle"}, "microwave"
        )

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        x = rng.uniform(0.40, 0.50)
        y = rng.uniform(-0.20, 0.10)
        yaw = np.deg2rad(rng.uniform(-22.5, 22.5))
        self.start_angle = float(np.deg2rad(rng.uniform(80.0, 100.0)))
        self.microwave.set_root_pose(yaw_pose(x, y, TABLE_TOP_Z, yaw))
        self.microwave.set_qpos(np.array([self.start_angle]))
        self.microwave.set_qvel(np.zeros(1))
        self.variation = 0
        self.episode_instruction = self.instruction

    def angle(self) -> float:
        return float(self.microwave.get_qpos()[0])

    def evaluate(self) -> bool:
        return self.joint_moved(self.start_angle, self.angle(), SUCCESS_ANGLE, -1)

    def _push_pose(self, theta: float, offset: float, turn: bool | None = None):
        """TCP pose (world) touching the door's outer face at PUSH_R when the door is at `theta`."""
        hinge = (-DEPTH / 2 - DOOR_T / 2, WIDTH / 2 - 0.005)
        root = self.microwave.get_root_pose()
        return door_push_pose(root, hinge, theta, PUSH_R, PUSH_Z, DOOR_T / 2 + offset, turn)

    def demonstration(self):
        theta0 = self.angle()
        angles = (theta0 - np.deg2rad(30), theta0 - np.deg2rad(60), max(theta0 - np.deg2rad(87), 0.0))
        yield from push_door_shut(self._push_pose, theta0, 0.12, angles)
