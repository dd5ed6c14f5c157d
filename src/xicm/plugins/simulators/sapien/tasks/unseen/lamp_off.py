"""lamp_off (unseen, level 1).

Task description:
    A desk lamp stands on the table: a round black base with a red push button at its front
    (towards the robot), a stem at the back and an arm reaching further back to a green shade
    with a bulb under it (out of the robot arm's way). The lamp is lit (the bulb glows). The
    robot presses the button down with its closed gripper, which switches the light off.

Randomisations:
    - lamp centre x in [0.15, 0.35] m, y in [-0.20, 0.20] m, yaw in [-90, 90] degrees (RLBench's
      default is [-180, 180]; beyond about 125 degrees the stem and shade stand between the
      robot and the button, and the demonstrator's press failed in 6 of 9 such seeds;
      simulator.scenes: rlbench draws [-180, 180] and redraws scenes the demonstrator fails);
    - the direction of the lamp's arm: in [-30, 30] degrees from straight back (simulator.scenes:
      rlbench: straight back, as RLBench's lamp is one model).

Success conditions:
    The button has been pressed in by more than 3 mm, which switched the light off (every
    press toggles the light; a press is counted again only after the button came back up),
    and the light is off.
    Under simulator.scenes: rlbench, RLBench's JointCondition: the button is in by more than 3 mm
    now (not latched; the spring lifts it back); the first press switches the light and nothing
    switches it back. The demonstrator then ends holding the button in (with success read only
    after key actions, success_check: per_action, a lifted button is a failure).
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_cylinder, look, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, frame_quat, snap_to_grid, wrist_friendly

BASE_R, BASE_H = 0.075, 0.02
BUTTON_X = -0.04  # the button sits at the front of the base
CAP_R, CAP_OUT = 0.014, 0.012  # cap radius and how far it stands out of the base
TRAVEL = 0.010
PRESSED = 0.003  # a press that switches the light
RELEASED = 0.0015  # the button must come back above this before the next press counts
STEM_X, STEM_TOP = 0.045, 0.36
ARM_LEN = 0.14
FINGERTIP = 0.0095  # the closed fingertips reach this far below the TCP
PRESS_DEPTH = 0.0065  # the demonstrator's press (1 cm grid: the cap top is placed so this is exact)
BULB_OFF = ((0.78, 0.78, 0.74, 1.0), (0.0, 0.0, 0.0, 0.0))
BULB_ON = ((1.0, 0.90, 0.45, 1.0), (1.0, 0.80, 0.30, 1.5))  # base colour, emission (rgb, strength)


class LampTask(Task):
    """A desk lamp with a push button that toggles its light; `start_lit` says how it starts."""

    split = "level1"
    object_names = ("lamp", "lamp button")
    start_lit: bool

    def load(self) -> None:
        """Nothing to build before the arm's direction is known; see initialise()."""
        self.lamp = None

    def _build(self, arm_yaw: float, pose: sapien.Pose):
        black = look((0.08, 0.08, 0.09), roughness=0.4, metallic=0.3)
        ab = self.world.scene.create_articulation_builder()
        body = ab.create_link_builder()
        body.set_name("lamp")
        add_cylinder(body, BASE_R, BASE_H / 2, sapien.Pose([0, 0, BASE_H / 2]), black, density=2000.0)
        add_cylinder(body, 0.02, 0.001, sapien.Pose([BUTTON_X, 0, BASE_H + 0.001]), (0.3, 0.3, 0.3), collide=False)
        stem_half = (STEM_TOP - BASE_H) / 2
        add_cylinder(body, 0.01, stem_half, sapien.Pose([STEM_X, 0, BASE_H + stem_half]), black)
        arm = yaw_pose(STEM_X, 0, STEM_TOP, arm_yaw)  # the arm points away from the robot
        add_cylinder(body, 0.008, ARM_LEN / 2, arm * sapien.Pose([ARM_LEN / 2, 0, 0]), black, axis="x")
        add_cylinder(body, 0.015, 0.015, arm, black, axis="y")  # joint knuckle
        # the shade (two cylinders: a cone's look) hangs at the arm's end, the bulb below it
        green = look((0.10, 0.38, 0.22), roughness=0.3, metallic=0.2)
        shade = self.world_point(arm, [ARM_LEN, 0, 0])
        add_cylinder(body, 0.028, 0.012, sapien.Pose(shade + [0, 0, -0.004]), green)
        add_cylinder(body, 0.055, 0.02, sapien.Pose(shade + [0, 0, -0.034]), green)
        self.bulb_look = look(BULB_OFF[0][:3], roughness=0.2)
        body.add_sphere_visual(sapien.Pose(shade + [0, 0, -0.058]), 0.024, self.bulb_look)

        cap = ab.create_link_builder(body)
        cap.set_name("button")
        cap.set_joint_name("press")
        # joint x axis -> world -z: q > 0 is "pressed in"
        down = sapien.Pose([BUTTON_X, 0, BASE_H], [np.cos(np.pi / 4), 0, np.sin(np.pi / 4), 0])
        cap.set_joint_properties("prismatic", [[0.0, TRAVEL]], down, sapien.Pose(q=down.q), damping=2.0)
        add_cylinder(cap, CAP_R, (CAP_OUT + TRAVEL) / 2, sapien.Pose([0, 0, (CAP_OUT - TRAVEL) / 2]), "red",
                     density=300.0)
        art = self.objects.articulation(ab, {"lamp": "lamp", "button": "lamp button"}, "lamp", pose)
        joint = art.get_active_joints()[0]
        joint.set_drive_property(800.0, 5.0)  # a spring that pushes the cap back up
        joint.set_drive_target(0.0)
        art.get_links()[1].disable_gravity = True
        return art

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        x = rng.uniform(0.15, 0.35)
        y = rng.uniform(-0.20, 0.20)
        yaw = np.deg2rad(rng.uniform(*self.span(ours=(-90.0, 90.0), rlbench=(-180.0, 180.0))))
        self.arm_yaw = 0.0 if self.rlbench_scenes else float(np.deg2rad(rng.uniform(-30.0, 30.0)))
        self.lamp = self._build(self.arm_yaw, yaw_pose(x, y, TABLE_TOP_Z, yaw))
        self.lamp.set_qpos(np.zeros(1))
        self.lamp.set_qvel(np.zeros(1))
        self.lit = self.start_lit
        self.presses = 0
        self.held = False  # the button is in (pressed and not yet released)
        self._show_light()
        self.variation = 0
        self.episode_instruction = self.instruction

    def _show_light(self) -> None:
        colour, emission = BULB_ON if self.lit else BULB_OFF
        self.bulb_look.set_base_color(list(colour))
        self.bulb_look.set_emission(list(emission))

    def depth(self) -> float:
        return float(self.lamp.get_qpos()[0])

    def on_frame(self) -> None:
        depth = self.depth()
        if not self.held and depth > PRESSED:
            self.held = True
            self.presses += 1
            if not (self.rlbench_scenes and self.presses > 1):  # RLBench's bulb never switches back
                self.lit = not self.lit
                self._show_light()
        elif self.held and depth < RELEASED:
            self.held = False

    def evaluate(self) -> bool:
        self.on_frame()
        if self.rlbench_scenes:
            return self.depth() > PRESSED
        return self.presses > 0 and self.lit != self.start_lit

    def demonstration(self):
        root = self.lamp.get_root_pose()
        rot = root.to_transformation_matrix()[:3, :3]
        down = np.array([0.0, 0.0, -1.0])
        # hand x along the lamp's front-back axis: the wide hand stays clear of the stem behind
        quat = wrist_friendly(frame_quat(rot[:, 0], np.cross(down, rot[:, 0]), down))
        top = self.world_point(root, [BUTTON_X, 0, BASE_H + CAP_OUT])
        press = snap_to_grid(top + [0.0, 0.0, FINGERTIP - PRESS_DEPTH])
        yield self.key(press + [0.0, 0.0, 0.08], quat, gripper_open=False)
        yield self.key(press, quat, gripper_open=False)
        if not self.rlbench_scenes:  # RLBench's rule holds only while pressed: the demo ends there
            yield self.key(press + [0.0, 0.0, 0.08], quat, gripper_open=False)


class LampOff(LampTask):
    name = "lamp_off"
    max_control_steps = 46  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    instruction = "turn off the light"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "turn off the light",
        "press the button to turn off the lamp",
        "press the light switch",
        "turn the lamp off",
        "close the gripper and press on the button until the light turns off",
    )
    start_lit = True
