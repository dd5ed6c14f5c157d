"""close_fridge (unseen, level 1).

Task description:
    A small fridge stands on the table facing the robot: a tall white body with a freezer door
    on top and a larger fridge door below (which stays shut), both hinged on the left (seen from
    the robot). The top door stands open; the robot pushes it shut with its closed gripper.

Randomisations:
    - fridge yaw in [-45, 45] degrees, centre x in [0.42, 0.52] m, y in [-0.12, 0.12] m, shifted
      by up to (-0.08, -0.24) m in proportion to a clockwise yaw (which swings the open door out
      to the left and back, beyond reach otherwise);
    - the top door's opening angle in [70, 100] degrees.

Success conditions:
    The top door has been closed by more than 30 degrees from its opening angle at the start.
    Under simulator.scenes: rlbench, RLBench's JointCondition: the joint moved by more than that
    from its start angle in either direction (|change|): opening it further counts too where the
    hinge allows it.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, look, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, door_push_pose, push_door_shut

DEPTH, WIDTH, HEIGHT = 0.24, 0.25, 0.44
SPLIT_Z = 0.25  # height of the gap between the bottom and the top door
DOOR_T = 0.025  # door thickness
DOOR_W = WIDTH - 0.01  # door width, hinge to free edge
TOP_DOOR = (SPLIT_Z + 0.005, HEIGHT - 0.005)  # bottom and top edge of the top door
PUSH_R = 0.17  # distance from the hinge at which the demonstrator pushes
PUSH_Z = TOP_DOOR[1] - 0.03  # TCP height above the table while pushing: the hand stays above the door
SUCCESS_ANGLE = np.deg2rad(30.0)


class CloseFridge(Task):
    name = "close_fridge"
    max_control_steps = 62  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "level1"
    instruction = "close fridge"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "close fridge",
        "close the fridge",
        "shut the fridge",
        "close the fridge door",
        "swing the fridge door shut",
    )
    object_names = ("fridge", "fridge top door", "fridge bottom door")

    def load(self) -> None:
        shell = look((0.93, 0.93, 0.91), roughness=0.35)
        inside = (0.55, 0.66, 0.75)
        chrome = look((0.7, 0.7, 0.72), roughness=0.2, metallic=0.8)
        ab = self.world.scene.create_articulation_builder()
        body = ab.create_link_builder()
        body.set_name("body")
        hx, hy, wall = DEPTH / 2, WIDTH / 2, 0.015
        add_box(body, [hx, hy, wall / 2], sapien.Pose([0, 0, wall / 2]), shell)  # floor
        add_box(body, [hx, hy, wall / 2], sapien.Pose([0, 0, HEIGHT - wall / 2]), shell)  # roof
        add_box(body, [wall / 2, hy, HEIGHT / 2], sapien.Pose([hx - wall / 2, 0, HEIGHT / 2]), shell)  # back
        for side in (-1, 1):
            add_box(body, [hx, wall / 2, HEIGHT / 2], sapien.Pose([0, side * (hy - wall / 2), HEIGHT / 2]), shell)
        # the shelf between freezer and fridge, and a pale inner back wall
        add_box(body, [hx - wall, hy - wall, 0.008], sapien.Pose([0, 0, SPLIT_Z]), shell)
        add_box(body, [0.001, hy - wall, HEIGHT / 2 - wall], sapien.Pose([hx - wall - 0.001, 0, HEIGHT / 2]), inside,
                collide=False)

        # doors hang on hinges at the front left corner; joint x axis = world -z, so q > 0
        # swings the free edge towards the robot
        turn = [np.cos(np.pi / 4), 0, np.sin(np.pi / 4), 0]
        links = {"body": "fridge"}
        for name, (z0, z1) in (("top_door", TOP_DOOR), ("bottom_door", (0.005, SPLIT_Z - 0.005))):
            door = ab.create_link_builder(body)
            door.set_name(name)
            door.set_joint_name(f"{name}_hinge")
            hinge = sapien.Pose([-hx - DOOR_T / 2, hy - 0.005, (z0 + z1) / 2], turn)
            if name == "top_door":
                limits = [[0.0, np.deg2rad(120.0)]]
                door.set_joint_properties("revolute", limits, hinge, sapien.Pose(q=turn), friction=0.0, damping=0.3)
            else:  # the bottom door stays shut
                door.set_joint_properties("fixed", [], hinge, sapien.Pose(q=turn))
            half_h = (z1 - z0) / 2
            # door frame = body axes at the hinge; the door extends along -y
            add_box(door, [DOOR_T / 2, DOOR_W / 2, half_h], sapien.Pose([0, -DOOR_W / 2, 0]), shell, density=300.0)
            # a vertical bar handle near the free edge
            bar = sapien.Pose([-DOOR_T / 2 - 0.022, -DOOR_W + 0.03, 0])
            add_cylinder(door, 0.008, min(half_h - 0.03, 0.08), bar, chrome, axis="z", collide=False)
            for end in (-1, 1):
                post = sapien.Pose([-DOOR_T / 2 - 0.011, -DOOR_W + 0.03, end * (min(half_h - 0.03, 0.08) - 0.01)])
                add_box(door, [0.011, 0.005, 0.005], post, chrome, collide=False)
            links[name] = "fridge top door" if name == "top_door" else "fridge bottom door"
        self.fridge = self.objects.articulation(ab, links, "fridge")

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        yaw = np.deg2rad(rng.uniform(-45.0, 45.0))
        # turned clockwise, the open door swings out to the left and back: keep it within reach
        cw = max(0.0, -yaw) / (np.pi / 4)
        x = rng.uniform(0.42, 0.52) - 0.08 * cw
        y = rng.uniform(-0.12, 0.12) - 0.24 * cw
        self.start_angle = float(np.deg2rad(rng.uniform(70.0, 100.0)))
        self.fridge.set_root_pose(yaw_pose(x, y, TABLE_TOP_Z, yaw))
        self.fridge.set_qpos(np.array([self.start_angle]))
        self.fridge.set_qvel(np.zeros(1))
        self.variation = 0
        self.episode_instruction = self.instruction

    def angle(self) -> float:
        """Opening angle of the top door (radians)."""
        return float(self.fridge.get_qpos()[0])

    def evaluate(self) -> bool:
        return self.joint_moved(self.start_angle, self.angle(), SUCCESS_ANGLE, -1)

    def _push_pose(self, theta: float, offset: float, turn: bool | None = None):
        """TCP pose (world) `offset` off the top door's outer face at PUSH_R when it is open by `theta`."""
        hinge = (-DEPTH / 2 - DOOR_T / 2, WIDTH / 2 - 0.005)
        root = self.fridge.get_root_pose()
        return door_push_pose(root, hinge, theta, PUSH_R, PUSH_Z, DOOR_T / 2 + offset, turn)

    def demonstration(self):
        theta0 = self.angle()
        angles = (theta0 - np.deg2rad(20), theta0 - np.deg2rad(38), theta0 - np.deg2rad(55))
        yield from push_door_shut(self._push_pose, theta0, 0.06, angles)
