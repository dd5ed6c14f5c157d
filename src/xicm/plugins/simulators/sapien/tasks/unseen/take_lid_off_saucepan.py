"""take_lid_off_saucepan (unseen, level 2).

Task description:
    A steel saucepan with a long handle stands on the table, closed by a glass lid with a
    round knob in its middle. The robot grips the knob from above and lifts the lid off the
    pan, holding it up above the pan.

Randomisations:
    - saucepan centre x in [0.15, 0.40] m, y in [-0.20, 0.20] m;
    - the saucepan's yaw (the direction of its handle) in [-180, 180) degrees.

Success conditions:
    The lid is lifted above the pan (its underside at least 5 cm above the rim, its centre
    within the pan's radius + 5 cm of the pan's axis) AND the gripper still holds it.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, quantised

PAN_R, PAN_H = 0.09, 0.09  # pan body radius and height (the rim)
HANDLE_L = 0.16
LID_R, LID_T = 0.096, 0.005  # lid disc radius and thickness
STEM_R, STEM_H = 0.008, 0.020  # the knob's neck
KNOB_R, KNOB_H = 0.016, 0.015  # the knob the gripper holds
GRIP_Z = LID_T + STEM_H + 0.008  # TCP height above the lid's underside when gripping
LIFT = 0.15  # how far the demonstrator lifts the lid
LIFTED = 0.05  # the lid's underside must be this far above the rim
NEAR = PAN_R + 0.05  # ... with its centre this close to the pan's axis


class TakeLidOffSaucepan(Task):
    name = "take_lid_off_saucepan"
    max_control_steps = 48  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "level2"
    instruction = "take lid off the saucepan"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "take lid off the saucepan",
        "using the handle, lift the lid off of the pan",
        "remove the lid from the pan",
        "grip the saucepan's lid and remove it from the pan",
        "leave the pan open",
        "uncover the saucepan",
    )
    object_names = ("saucepan", "saucepan lid")

    def load(self) -> None:
        steel = look((0.72, 0.72, 0.75), roughness=0.25, metallic=0.9)
        black = (0.08, 0.08, 0.08)
        pb = self.world.scene.create_actor_builder()
        add_cylinder(pb, PAN_R, PAN_H / 2, sapien.Pose([0, 0, PAN_H / 2]), steel, material=physical(0.8),
                     density=1500.0)
        add_cylinder(pb, PAN_R + 0.003, 0.003, sapien.Pose([0, 0, PAN_H - 0.003]), steel, collide=False)  # rim
        inside = sapien.Pose([0, 0, PAN_H + 0.0005])
        add_cylinder(pb, PAN_R - 0.005, 0.0005, inside, (0.35, 0.35, 0.37), collide=False)  # the dark inside
        handle = sapien.Pose([PAN_R + HANDLE_L / 2 - 0.01, 0, PAN_H - 0.015])
        add_box(pb, [HANDLE_L / 2, 0.012, 0.008], handle, black, density=300.0)
        self.pan = self.objects.actor(pb, "saucepan")

        lb = self.world.scene.create_actor_builder()
        glass = look((0.55, 0.62, 0.65), roughness=0.05)
        # lid frame: origin at the centre of its underside
        add_cylinder(lb, LID_R, LID_T / 2, sapien.Pose([0, 0, LID_T / 2]), glass, material=physical(0.8),
                     density=2500.0)
        add_cylinder(lb, LID_R, 0.004, sapien.Pose([0, 0, 0.002]), steel, collide=False)  # steel rim band
        add_cylinder(lb, STEM_R, STEM_H / 2, sapien.Pose([0, 0, LID_T + STEM_H / 2]), black, density=800.0)
        knob = sapien.Pose([0, 0, LID_T + STEM_H + KNOB_H / 2 - 0.005])
        add_cylinder(lb, KNOB_R, KNOB_H / 2, knob, black, material=physical(1.5), density=800.0)
        self.lid = self.objects.actor(lb, "saucepan lid")

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        x, y = rng.uniform(0.15, 0.40), rng.uniform(-0.20, 0.20)
        yaw = rng.uniform(-np.pi, np.pi)
        self.pan.set_pose(yaw_pose(x, y, TABLE_TOP_Z, yaw))
        self.lid.set_pose(yaw_pose(x, y, TABLE_TOP_Z + PAN_H + 0.0005, rng.uniform(-np.pi, np.pi)))
        for actor in (self.pan, self.lid):
            body = actor.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
            body.set_linear_velocity([0, 0, 0])
            body.set_angular_velocity([0, 0, 0])
        self.variation = 0
        self.episode_instruction = self.instruction

    def lid_lifted(self) -> bool:
        """Whether the lid hangs above the pan (lifted off its rim, not moved away)."""
        lid, pan = np.asarray(self.lid.pose.p, dtype=float), np.asarray(self.pan.pose.p, dtype=float)
        high = lid[2] - (pan[2] + PAN_H) > LIFTED
        return bool(high and np.linalg.norm(lid[:2] - pan[:2]) < NEAR)

    def evaluate(self) -> bool:
        return self.lid_lifted() and self.lid.per_scene_id in self.grasped()

    def demonstration(self):
        grip = np.asarray(self.lid.pose.p, dtype=float) + [0, 0, GRIP_Z]
        yield quantised(self.key(grip + [0, 0, 0.10], gripper_open=True))
        yield quantised(self.key(grip, gripper_open=False))
        yield quantised(self.key(grip + [0, 0, LIFT], gripper_open=False))
