"""turn_tap (seen).

Task description:
    A faucet stands on the table facing the robot: a central pillar with a spout and, on
    either side, a tap with a cross-bar handle on a vertical valve. The robot grasps the bar
    of the named tap (left or right, as seen from the robot) at its pivot from above and
    turns it.

Randomisations:
    - the tap to turn (variation 0: left, 1: right) when variations are sampled;
    - faucet centre x in [0.20, 0.35] m, y in [-0.15, 0.15] m, yaw in [-180, 180] degrees (RLBench's
      default base_rotation_bounds);
    - each handle's starting angle in [-20, 20] degrees.

Success conditions:
    The named tap's handle has turned by more than 90 degrees (either way) from its angle at
    the start of the episode.
"""

from __future__ import annotations

import numpy as np
import sapien


from ...objects import add_box, add_cylinder, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, quantised

SIDES = ("left", "right")
TAP_Y = 0.13  # valve centres on the faucet's local y axis (+y: the robot's left)
VALVE_R, VALVE_TOP = 0.02, 0.06
HUB_H = 0.015  # hub between the valve and the bar
BAR_HALF = (0.05, 0.008, 0.008)  # the cross bar, along the handle's local x
BAR_Z = HUB_H + BAR_HALF[2]  # bar centre above the valve top
TURN = np.deg2rad(115.0)  # how far the demonstrator turns
SUCCESS_ANGLE = np.pi / 2
DOWN = np.array([0.0, 1.0, 0.0, 0.0])
UP_AXIS = [np.cos(np.pi / 4), 0.0, -np.sin(np.pi / 4), 0.0]  # joint x axis -> world +z


def down_yaw(yaw: float) -> np.ndarray:
    """Gripper pointing down, turned by `yaw` about the world z axis (hand x at that yaw)."""
    return np.asarray((sapien.Pose(q=[np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)]) * sapien.Pose(q=DOWN)).q)


class TurnTap(Task):
    name = "turn_tap"
    max_control_steps = 90  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "seen"
    instruction = "turn left tap"
    phrasings = (  # RLBench's variation-0 phrasings, AGNOSTOS's instruction first
        "turn left tap",
        "rotate the left tap",
        "grasp the left tap and turn it",
    )
    object_names = ("left tap", "right tap", "faucet")

    def load(self) -> None:
        chrome = look((0.78, 0.78, 0.80), roughness=0.2, metallic=0.9)
        ab = self.world.scene.create_articulation_builder()
        body = ab.create_link_builder()
        body.set_name("faucet")
        add_box(body, [0.05, TAP_Y + 0.05, 0.005], sapien.Pose([0, 0, 0.005]), (0.9, 0.9, 0.88))  # base plate
        add_cylinder(body, 0.02, 0.06, sapien.Pose([0, 0, 0.06]), chrome)  # pillar
        add_cylinder(body, 0.011, 0.05, sapien.Pose([-0.05, 0, 0.11]), chrome, axis="x")  # spout
        add_cylinder(body, 0.011, 0.012, sapien.Pose([-0.095, 0, 0.096]), chrome)  # nozzle
        for side in (1, -1):
            valve = sapien.Pose([0, side * TAP_Y, (VALVE_TOP + 0.01) / 2])
            add_cylinder(body, VALVE_R, (VALVE_TOP - 0.01) / 2, valve, chrome)
        links = {"faucet": "faucet"}
        for side, sign, mark in (("left", 1, (0.85, 0.1, 0.1)), ("right", -1, (0.1, 0.25, 0.9))):
            handle = ab.create_link_builder(body)
            handle.set_name(f"{side}_tap")
            handle.set_joint_name(f"{side}_tap_joint")
            pivot = sapien.Pose([0, sign * TAP_Y, VALVE_TOP], UP_AXIS)
            limits = [[-np.pi * 0.95, np.pi * 0.95]]
            handle.set_joint_properties("revolute", limits, pivot, sapien.Pose(q=UP_AXIS), friction=0.02, damping=0.2)
            add_cylinder(handle, 0.009, HUB_H / 2, sapien.Pose([0, 0, HUB_H / 2]), chrome)
            add_box(handle, BAR_HALF, sapien.Pose([0, 0, BAR_Z]), chrome, material=physical(1.5), density=800.0)
            for end in (-1, 1):  # round knobs at the bar ends
                add_cylinder(handle, 0.011, 0.009, sapien.Pose([end * BAR_HALF[0], 0, BAR_Z]), chrome)
            cap = sapien.Pose([0, 0, BAR_Z + BAR_HALF[2] + 0.0005])
            add_cylinder(handle, 0.007, 0.0006, cap, mark, collide=False)  # hot / cold mark
            links[f"{side}_tap"] = f"{side} tap"
        self.faucet = self.objects.articulation(ab, links, "faucet")
        self.handles = [self.faucet.find_link_by_name(f"{s}_tap") for s in SIDES]

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        variation = int(rng.integers(2))
        self.variation = variation if sample_variation else 0
        self.episode_instruction = f"turn {SIDES[self.variation]} tap"
        x, y = rng.uniform(0.20, 0.35), rng.uniform(-0.15, 0.15)
        yaw = np.deg2rad(rng.uniform(-180.0, 180.0))
        self.faucet.set_root_pose(yaw_pose(x, y, TABLE_TOP_Z, yaw))  # spout (-x local) towards the robot
        self.start_q = np.deg2rad(rng.uniform(-20.0, 20.0, 2))
        self.faucet.set_qpos(self.start_q.copy())
        self.faucet.set_qvel(np.zeros(2))

    def turned(self) -> np.ndarray:
        return np.abs(self.faucet.get_qpos() - self.start_q)

    def evaluate(self) -> bool:
        return bool(self.turned()[self.variation] > SUCCESS_ANGLE)

    def demonstration(self):
        handle = self.handles[self.variation].entity_pose
        bar = self.world_point(handle, [0, 0, BAR_Z])
        bar_x = handle.to_transformation_matrix()[:3, 0]
        yaw = np.arctan2(bar_x[1], bar_x[0])
        yaw = (yaw + np.pi / 2) % np.pi - np.pi / 2  # the bar is symmetric: hand x along it, in [-90, 90)
        end = yaw - TURN if yaw > 0 else yaw + TURN  # turn towards the wrist's middle
        yield quantised(self.key(bar + [0, 0, 0.10], down_yaw(yaw), True))
        yield quantised(self.key(bar, down_yaw(yaw), False))
        yield quantised(self.key(bar, down_yaw(end), True))
        yield quantised(self.key(bar + [0, 0, 0.10], down_yaw(end), True))
