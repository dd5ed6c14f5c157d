"""unplug_charger (unseen, level 2).

Task description:
    A piece of wall stands on the table facing the robot with a surface-mounted socket on
    it, and a white phone charger is plugged into the socket, its two pins in the socket's
    holes. The robot grips the charger from the front (the gripper pointing into the wall and
    40 degrees down, fingers on the charger's sides) and pulls it straight out of the socket.

Randomisations:
    - wall centre x in [0.36, 0.44] m, y in [-0.15, 0.15] m, yaw in [-45, 45] degrees (RLBench's
      base_rotation_bounds);
    - the socket's position along the wall, -0.06 to 0.06 m from its centre.

Success conditions:
    Both pins of the charger are out of the socket (their tips more than 5 mm in front of
    the socket face, or away from its holes). Holding the charger afterwards is allowed.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, frame_quat, quantised, wrist_friendly

WALL_HALF = (0.01, 0.20, 0.16)  # the wall board: thickness, half width, half height
SOCKET_HALF = (0.011, 0.042, 0.042)  # the socket box on the wall's front
SOCKET_Z = 0.13  # socket centre above the table
PIN_Y = 0.0095  # the pins sit this far left and right of the socket centre
PIN_HALF = (0.0095, 0.0023, 0.0023)  # a pin: length, width, height
HOLE = 0.005  # the square holes the pins go into
CHARGER_HALF = (0.0225, 0.020, 0.024)  # the charger body: depth, half width, half height
GRIP_OUT = 0.028  # the TCP sits this far out from the socket face while gripping
PULL = 0.08  # how far the demonstrator pulls the charger out
PITCH = np.deg2rad(40.0)  # the gripper points this much below the horizontal (IK-friendly)


def _socket_face(builder, colour) -> None:
    """The socket box: a slab (front face at local x = -2 * SOCKET_HALF[0]) with two pin holes."""
    hx, hy, hz = SOCKET_HALF
    x = sapien.Pose([-hx, 0, 0])
    lo, hi = -HOLE / 2, HOLE / 2
    add_box(builder, [hx, hy, (hz + lo) / 2], x * sapien.Pose([0, 0, (-hz + lo) / 2]), colour)  # below the holes
    add_box(builder, [hx, hy, (hz - hi) / 2], x * sapien.Pose([0, 0, (hz + hi) / 2]), colour)  # above
    edges = [-hy, -PIN_Y - HOLE / 2, -PIN_Y + HOLE / 2, PIN_Y - HOLE / 2, PIN_Y + HOLE / 2, hy]
    for y0, y1 in zip(edges[0::2], edges[1::2]):  # beside and between the holes
        add_box(builder, [hx, (y1 - y0) / 2, HOLE / 2], x * sapien.Pose([0, (y0 + y1) / 2, 0]), colour)
    for y in (-PIN_Y, PIN_Y):  # the dark hole openings
        add_box(builder, [0.0005, HOLE / 2, HOLE / 2], sapien.Pose([-2 * hx - 0.0002, y, 0]), (0.15, 0.15, 0.15),
                collide=False)


class UnplugCharger(Task):
    name = "unplug_charger"
    max_control_steps = 74  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "level2"
    instruction = "unplug charger"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "unplug charger",
        "take the charger out of the wall",
        "grip the black charger and pull it out of its socket",
        "slide the plug out from the wall",
        "remove the charger from the mains",
        "get the charger from the wall plug",
    )
    object_names = ("charger", "wall socket", "wall")

    def load(self) -> None:
        wb = self.world.scene.create_actor_builder()
        wx, wy, wz = WALL_HALF
        add_box(wb, WALL_HALF, sapien.Pose([0, 0, wz]), (0.86, 0.82, 0.74))
        add_box(wb, [0.05, wy, 0.01], sapien.Pose([0.06, 0, 0.01]), (0.55, 0.45, 0.35))  # foot behind the wall
        add_box(wb, [0.004, wy, 0.012], sapien.Pose([-wx - 0.004, 0, 0.012]), (0.95, 0.95, 0.93))  # skirting
        self.wall = self.objects.actor(wb, "wall", kind="static")

        sb = self.world.scene.create_actor_builder()
        _socket_face(sb, (0.97, 0.97, 0.95))
        self.socket = self.objects.actor(sb, "wall socket", kind="static")

        cb = self.world.scene.create_actor_builder()
        white = (0.96, 0.96, 0.96)
        # charger frame: origin on its back face (against the socket), x pointing out of the wall
        add_box(cb, CHARGER_HALF, sapien.Pose([CHARGER_HALF[0], 0, 0]), white, material=physical(1.5),
                density=800.0)
        metal = look((0.75, 0.75, 0.78), roughness=0.3, metallic=0.8)
        for y in (-PIN_Y, PIN_Y):
            add_box(cb, PIN_HALF, sapien.Pose([-PIN_HALF[0], y, 0]), metal, material=physical(0.3), density=3000.0)
        port = sapien.Pose([2 * CHARGER_HALF[0] + 0.0005, 0, 0])
        add_box(cb, [0.0005, 0.006, 0.0025], port, (0.1, 0.1, 0.1), collide=False)  # USB port for the cable
        self.charger = self.objects.actor(cb, "charger")

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        x, y = rng.uniform(0.36, 0.44), rng.uniform(-0.15, 0.15)
        yaw = np.deg2rad(rng.uniform(-45.0, 45.0))
        along = rng.uniform(-0.06, 0.06)
        wall = yaw_pose(x, y, TABLE_TOP_Z, yaw)
        self.wall.set_pose(wall)
        self.socket_pose = wall * sapien.Pose([-WALL_HALF[0], along, SOCKET_Z])
        self.socket.set_pose(self.socket_pose)
        face = self.socket_pose * sapien.Pose([-2 * SOCKET_HALF[0], 0, 0])
        self.charger.set_pose(face * sapien.Pose(q=[0.0, 0.0, 0.0, 1.0]))  # x out of the wall
        body = self.charger.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
        body.set_linear_velocity([0, 0, 0])
        body.set_angular_velocity([0, 0, 0])
        self.variation = 0
        self.episode_instruction = self.instruction

    def pins_in_socket(self) -> bool:
        """Whether either pin's tip is still in (or at the mouth of) its hole."""
        for y in (-PIN_Y, PIN_Y):
            tip = self.world_point(self.charger.pose, [-2 * PIN_HALF[0], y, 0])
            local = np.asarray((self.socket_pose.inv() * sapien.Pose(tip)).p, dtype=float)
            at_hole = abs(abs(local[1]) - PIN_Y) < 0.008 and abs(local[2]) < 0.008
            if at_hole and local[0] > -2 * SOCKET_HALF[0] - 0.005:
                return True
        return False

    def evaluate(self) -> bool:
        return not self.pins_in_socket()

    def demonstration(self):
        m = self.charger.pose.to_transformation_matrix()
        out = m[:3, 0] * np.array([1.0, 1.0, 0.0])
        out /= np.linalg.norm(out)
        # pointing into the wall and down at PITCH (level, with hand x up, the pose would sit in
        # the Euler-angle singularity of the action text), the fingers closing on the charger's sides
        inward = -out * np.cos(PITCH) + np.array([0.0, 0.0, -np.sin(PITCH)])
        up = np.cross(np.cross(inward, [0.0, 0.0, 1.0]), inward)
        quat = wrist_friendly(frame_quat(up, np.cross(inward, up), inward))
        grip = m[:3, 3] + out * GRIP_OUT
        yield quantised(self.key(grip + out * 0.10, quat, True))
        yield quantised(self.key(grip, quat, False))
        yield quantised(self.key(grip + out * PULL, quat, False))
