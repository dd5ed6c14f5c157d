"""open_grill (unseen, level 1).

Task description:
    A barbecue grill stands on the table: a black fire box with a closed lid hinged along its
    back edge and a chrome bar handle on the lid's front. The robot grasps the handle from the
    front (pointing into the lid and down) and swings the lid up and back, holding it open.

Randomisations:
    - yaw in [-90, 90] degrees (the lid's front, with its handle, faces the robot at 0);
    - the grill is placed so that its handle lies at x in [0.18, 0.28] m, y in [-0.15, 0.15] m.

Success conditions:
    The lid has been opened by more than 50 degrees from its (closed) angle at the start.
    Under simulator.scenes: rlbench, RLBench's JointCondition: |change| from the start angle
    (the same here, as the lid starts at its closed stop).
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, frame_quat

HALF = (0.11, 0.16)  # half depth (x) and half width (y) of the grill
BODY_H, LID_H = 0.12, 0.07  # fire box height, lid height
HANDLE_OUT = 0.06  # the handle bar's centre in front of the lid's front face
HANDLE_Z = 0.035  # ... and its height above the lid's bottom edge
SUCCESS_ANGLE = np.deg2rad(50.0)
PITCH = np.deg2rad(45.0)  # the gripper points into the shut lid and 45 degrees down
# ... and keeps that world pitch while the lid swings up (the bar rolls between the finger pads):
# pointing forward, the Panda reaches the far, high open pose
PITCH_FOLLOW = 0.0
Y_AXIS = [np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)]  # joint x axis -> +y: q > 0 lifts the lid
# the handle in the lid's frame (origin on the hinge line, closed lid along -x)
BAR = np.array([-2 * HALF[0] - HANDLE_OUT, 0.0, HANDLE_Z])


class OpenGrill(Task):
    name = "open_grill"
    max_control_steps = 102  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "level1"
    instruction = "open the grill"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "open the grill",
        "grasp tha handle and raise the cover up to open the grill",
        "open the bbq",
        "open the barbecue",
    )
    object_names = ("grill", "grill lid", "grill lid handle")

    def load(self) -> None:
        black = look((0.10, 0.10, 0.11), roughness=0.5, metallic=0.3)
        chrome = look((0.75, 0.75, 0.78), roughness=0.2, metallic=0.9)
        hx, hy = HALF
        ab = self.world.scene.create_articulation_builder()
        body = ab.create_link_builder()
        body.set_name("grill")
        add_box(body, [hx, hy, BODY_H / 2], sapien.Pose([0, 0, BODY_H / 2]), black, density=800.0)
        for k in (-1, 0, 1):  # air vents on the front
            vent = sapien.Pose([-hx - 0.001, k * 0.07, BODY_H * 0.45])
            add_box(body, [0.001, 0.025, 0.006], vent, (0.35, 0.35, 0.36), collide=False)
        for k in range(-5, 6):  # the grate under the lid (visual only, flush with the top)
            bar = sapien.Pose([k * 0.018, 0, BODY_H - 0.003])
            add_cylinder(body, 0.003, hy - 0.015, bar, (0.45, 0.45, 0.47), axis="y", collide=False)
        for side in (-1, 1):  # side handles
            add_box(body, [0.04, 0.012, 0.006], sapien.Pose([0, side * (hy + 0.012), BODY_H - 0.02]), chrome,
                    collide=False)

        lid = ab.create_link_builder(body)
        lid.set_name("lid")
        lid.set_joint_name("lid_hinge")
        hinge = sapien.Pose([hx, 0, BODY_H], Y_AXIS)
        lid.set_joint_properties("revolute", [[0.0, np.deg2rad(105.0)]], hinge, sapien.Pose(q=Y_AXIS), friction=0.0,
                                 damping=0.5)
        # lid frame = body axes at the hinge; closed, the lid covers the fire box along -x
        add_box(lid, [hx, hy, LID_H / 2 - 0.01], sapien.Pose([-hx, 0, LID_H / 2 - 0.01]), black, density=200.0)
        add_box(lid, [hx - 0.02, hy - 0.02, 0.01], sapien.Pose([-hx, 0, LID_H - 0.01]), black, density=200.0)
        add_cylinder(lid, 0.012, 0.004, sapien.Pose([-hx, 0, LID_H + 0.004]), chrome, collide=False)  # thermometer

        handle = ab.create_link_builder(lid)
        handle.set_name("handle")
        handle.set_joint_name("handle_joint")
        handle.set_joint_properties("fixed", [], sapien.Pose(BAR), sapien.Pose())
        add_cylinder(handle, 0.009, 0.075, None, chrome, material=physical(1.5), axis="y")
        for side in (-1, 1):  # posts between the bar and the lid
            add_box(handle, [HANDLE_OUT / 2, 0.006, 0.006], sapien.Pose([HANDLE_OUT / 2, side * 0.06, 0]), chrome)
        self.grill = self.objects.articulation(
            ab, {"grill": "grill", "lid": "grill lid", "handle": "grill lid handle"}, "grill"
        )
        # a loose hinge: let go below the vertical, the lid falls shut (PhysX's default joint
        # friction would hold it wherever it was left)
        self.grill.get_active_joints()[0].set_friction(0.0)
        self.grill.set_sleep_threshold(0.0)

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        yaw = np.deg2rad(rng.uniform(-90.0, 90.0))
        handle = np.array([rng.uniform(0.18, 0.28), rng.uniform(-0.15, 0.15)])
        # the handle bar lies HALF[0] + HANDLE_OUT in front of the grill's centre
        centre = handle + (HALF[0] + HANDLE_OUT) * np.array([np.cos(yaw), np.sin(yaw)])
        self.grill.set_root_pose(yaw_pose(centre[0], centre[1], TABLE_TOP_Z, yaw))
        self.grill.set_qpos(np.zeros(1))
        self.grill.set_qvel(np.zeros(1))
        self.start_angle = 0.0
        self.variation = 0
        self.episode_instruction = self.instruction

    def angle(self) -> float:
        """How far the lid is open (0 = shut)."""
        return float(self.grill.get_qpos()[0])

    def evaluate(self) -> bool:
        return self.joint_moved(self.start_angle, self.angle(), SUCCESS_ANGLE, +1)

    def _grasp(self, phi: float, pitch: float = PITCH):
        """TCP pose on the handle bar when the lid is open by `phi`: the gripper points into the
        lid and down by `pitch` (relative to the lid), its fingers closing across the bar."""
        root = self.grill.get_root_pose()
        c, s = np.cos(phi), np.sin(phi)
        lid_rot = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])  # rotation about the hinge (+y) by phi
        hinge = np.array([HALF[0], 0.0, BODY_H])
        rot = root.to_transformation_matrix()[:3, :3]
        approach = rot @ lid_rot @ np.array([np.cos(pitch), 0.0, -np.sin(pitch)])
        fingers = rot @ lid_rot @ np.array([np.sin(pitch), 0.0, np.cos(pitch)])
        # hand x along the lid's +y: a quarter turn from the Panda's natural wrist angle for this
        # approach, the side that leaves joint 7 most room (the other side ends near its limit)
        quat = frame_quat(np.cross(fingers, approach), fingers, approach)
        p = self.world_point(root, hinge + lid_rot @ BAR)
        return p, quat, approach

    def demonstration(self):
        p, q, approach = self._grasp(0.0)
        # first turn the wrist while pointing down (above the handle), then tilt towards the lid
        _, q_down, _ = self._grasp(0.0, pitch=np.pi / 2)
        yield self.key(p - approach * 0.10 + [0.0, 0.0, 0.06], q_down, gripper_open=True)
        yield self.key(p - approach * 0.10, q, gripper_open=True)
        yield self.key(p, q, gripper_open=True)
        yield self.key(p, q, gripper_open=False)
        for deg in (20.0, 40.0, 60.0):  # swing the lid up along the handle's arc, holding it
            phi = np.deg2rad(deg)
            p, q, _ = self._grasp(phi, PITCH - (1.0 - PITCH_FOLLOW) * phi)
            yield self.key(p, q, gripper_open=False)
