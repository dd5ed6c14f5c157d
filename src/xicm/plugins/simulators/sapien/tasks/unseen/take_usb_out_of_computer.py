"""take_usb_out_of_computer (unseen, level 2).

Task description:
    A desktop computer (a grey tower case) stands on the table facing the robot, with a USB
    stick plugged into a port near the top of its front panel, the stick sticking out
    towards the robot. The robot grips the stick from above, pulls it straight out of the
    port, puts it down on the table and lets go of it.

Randomisations:
    - computer centre x in [0.40, 0.48] m, y in [-0.15, 0.15] m, yaw in [-60, 60] degrees (RLBench's
      default is [-180, 180]; from about 75 degrees the ports face away and the stick is out of
      the demonstrator's reach; simulator.scenes: rlbench draws [-180, 180] and redraws scenes the demonstrator fails);
    - which of the two front ports (left or right of the centre) holds the stick.

Success conditions:
    The stick's plug is out of the port (its tip more than 5 mm in front of the panel, or
    away from the port opening) AND the gripper holds nothing.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, down_quat, quantised, wrist_friendly

DEPTH, WIDTH, HEIGHT = 0.30, 0.17, 0.32
PORT_Z = HEIGHT - 0.025  # centre height of the front USB ports
PORT_Y = (0.025, -0.025)  # the two front ports, left and right of the centre
HOLE = (0.013, 0.0052)  # width and height of a port opening (the plug is 12 x 4.5 mm)
SLOT_D = 0.015  # depth of the port
PLUG_HALF = (0.006, 0.006, 0.00225)  # the metal plug: length, width, thickness
BODY_HALF = (0.025, 0.009, 0.004)  # the stick's plastic body
GRIP_AT = 0.030  # the fingers hold the stick this far in front of the panel
PULL = 0.06  # how far the demonstrator pulls the stick out


class TakeUsbOutOfComputer(Task):
    name = "take_usb_out_of_computer"
    max_control_steps = 72  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "level2"
    instruction = "take usb out of computer"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "take usb out of computer",
        "remove the usb stick from its port",
        "retrieve the usb stick",
        "grasp the usb stick and slide it out of the pc",
        "get a hold of the usb stick and pull it out of the desktop computer",
    )
    object_names = ("computer", "usb stick")

    def load(self) -> None:
        case = (0.55, 0.56, 0.58)
        front = (0.20, 0.20, 0.22)
        b = self.world.scene.create_actor_builder()
        hx, hy = DEPTH / 2, WIDTH / 2
        # the case behind the port depth, then the front panel built around the two port openings
        add_box(b, [hx - SLOT_D / 2, hy, HEIGHT / 2], sapien.Pose([SLOT_D / 2, 0, HEIGHT / 2]), case)
        fx = -hx + SLOT_D / 2
        lo, hi = PORT_Z - HOLE[1] / 2, PORT_Z + HOLE[1] / 2
        add_box(b, [SLOT_D / 2, hy, lo / 2], sapien.Pose([fx, 0, lo / 2]), front)  # below the ports
        top = HEIGHT - hi
        add_box(b, [SLOT_D / 2, hy, top / 2], sapien.Pose([fx, 0, hi + top / 2]), front)  # above
        # beside and between the openings, at port height
        edges = sorted([-hy, hy] + [y + s * HOLE[0] / 2 for y in PORT_Y for s in (-1, 1)])
        for y0, y1 in zip(edges[0::2], edges[1::2]):
            add_box(b, [SLOT_D / 2, (y1 - y0) / 2, HOLE[1] / 2], sapien.Pose([fx, (y0 + y1) / 2, PORT_Z]), front)
        for y in PORT_Y:  # the dark inside of each port
            add_box(b, [0.0005, HOLE[0] / 2, HOLE[1] / 2], sapien.Pose([-hx + SLOT_D, y, PORT_Z]), "black",
                    collide=False)
        # power button, drive bay and side vents
        add_cylinder(b, 0.012, 0.001, sapien.Pose([-hx - 0.001, 0, HEIGHT - 0.065]), (0.2, 0.5, 0.95), axis="x",
                     collide=False)
        add_box(b, [0.001, 0.065, 0.018], sapien.Pose([-hx - 0.001, 0, HEIGHT - 0.12]), (0.12, 0.12, 0.13),
                collide=False)
        for k in range(6):
            vent = sapien.Pose([0.02 + 0.02 * k, hy + 0.0005, HEIGHT * 0.55])
            add_box(b, [0.004, 0.0005, 0.06], vent, (0.3, 0.3, 0.32), collide=False)
        self.computer = self.objects.actor(b, "computer", kind="static")

        s = self.world.scene.create_actor_builder()
        metal = look((0.75, 0.75, 0.78), roughness=0.3, metallic=0.8)
        add_box(s, PLUG_HALF, sapien.Pose([-PLUG_HALF[0], 0, 0]), metal, material=physical(0.3), density=2000.0)
        add_box(s, BODY_HALF, sapien.Pose([BODY_HALF[0], 0, 0]), (0.10, 0.30, 0.85), material=physical(1.5),
                density=1000.0)
        add_box(s, [0.006, 0.0035, 0.0045], sapien.Pose([2 * BODY_HALF[0] - 0.008, 0, 0]), "white",
                collide=False)  # a label near the end
        self.stick = self.objects.actor(s, "usb stick")

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        x, y = rng.uniform(0.40, 0.48), rng.uniform(-0.15, 0.15)
        yaw = np.deg2rad(rng.uniform(*self.span(ours=(-60.0, 60.0), rlbench=(-180.0, 180.0))))
        self.port = int(rng.integers(2))
        self.computer_pose = yaw_pose(x, y, TABLE_TOP_Z, yaw)
        self.computer.set_pose(self.computer_pose)
        # the stick's frame: origin where the plug meets the body, x pointing out of the port
        mouth = self.world_point(self.computer_pose, [-DEPTH / 2, PORT_Y[self.port], PORT_Z])
        self.stick.set_pose(yaw_pose(*mouth, yaw + np.pi))
        body = self.stick.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
        body.set_linear_velocity([0, 0, 0])
        body.set_angular_velocity([0, 0, 0])
        self.variation = 0
        self.episode_instruction = self.instruction

    def plug_in_port(self) -> bool:
        """Whether the tip of the stick's plug is still in (or at the mouth of) the port."""
        tip = self.world_point(self.stick.pose, [-2 * PLUG_HALF[0], 0, 0])
        local = np.asarray((self.computer_pose.inv() * sapien.Pose(tip)).p, dtype=float)
        at_port = abs(local[1] - PORT_Y[self.port]) < 0.012 and abs(local[2] - PORT_Z) < 0.012
        return bool(at_port and local[0] > -DEPTH / 2 - 0.005)

    def evaluate(self) -> bool:
        return not self.plug_in_port() and not self.grasped()

    def demonstration(self):
        m = self.stick.pose.to_transformation_matrix()
        out = m[:3, 0] * np.array([1.0, 1.0, 0.0])
        out /= np.linalg.norm(out)
        quat = wrist_friendly(down_quat(np.arctan2(out[1], out[0])))  # fingers close across the stick
        grip = m[:3, 3] + out * GRIP_AT
        pulled = grip + out * PULL
        down = [*pulled[:2], TABLE_TOP_Z + BODY_HALF[2] + 0.022]  # fingertips just above the table
        yield quantised(self.key(grip + [0, 0, 0.10], quat, True))
        yield quantised(self.key(grip, quat, False))
        yield quantised(self.key(pulled, quat, False))
        yield quantised(self.key(down, quat, True))
        yield quantised(self.key(np.add(down, [0, 0, 0.10]), quat, True))
