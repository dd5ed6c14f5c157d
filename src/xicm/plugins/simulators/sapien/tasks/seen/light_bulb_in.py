"""light_bulb_in (seen).

Task description:
    Two light bulbs, one with red glass and one with green glass, stand screw-base down in
    two small holders; a lamp (base, column and an empty socket on top) stands behind them.
    The robot picks the named bulb up by its glass, lowers its screw base into the lamp's
    socket and lets go.

Randomisations:
    - the bulb to screw in (variation 0: red; red or green when variations are sampled);
    - lamp centre x in [0.26, 0.32] m, y in [-0.05, 0.05] m;
    - holder centres x in [0.00, 0.14] m, |y| in [0.12, 0.24] m, one on each side, which
      colour goes left drawn at random.

Success conditions:
    The named bulb stands in the lamp's socket (screw base within 1.5 cm of the socket axis
    and resting at the socket floor) AND nothing is grasped.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, look, physical
from ...scene import TABLE_TOP_Z
from ...task_base import Task, down_quat, snap_to_grid

COLOURS = ("red", "green")
BASE_R, BASE_H = 0.011, 0.022  # the bulb's screw base
GLASS_R, GLASS_H = 0.02, 0.038  # the bulb's glass: a cylinder with a half-sphere on top
RING_IN, RING_WALL, RING_H = 0.02, 0.004, BASE_H  # socket / holder ring
HOLDER_H = 0.03  # holder stand height (the ring sits on it)
LAMP_H = 0.12  # lamp column height (the socket sits on it)
GRIP_Z = BASE_H + GLASS_H / 2  # grasp height above the bulb's bottom
SOCKET_BOTTOM, SOCKET_TOP = BASE_R + 0.0015, 0.022  # the lamp socket's inner radius at its floor and rim


def add_ring(builder, z0: float, colour, r_bottom: float = RING_IN, r_top: float = RING_IN) -> None:
    """A short upright tube of 16 flat wall segments (bottom at height z0), flaring from inner
    radius r_bottom to r_top."""
    n = 16
    alpha = np.arctan((r_top - r_bottom) / RING_H)
    length = np.hypot(RING_H, r_top - r_bottom)
    r = (r_bottom + r_top) / 2 + RING_WALL / 2
    width = 2 * (r_top + RING_WALL) * np.tan(np.pi / n) * 1.05
    for k in range(n):
        phi = 2 * np.pi * k / n
        turn = sapien.Pose(
            [r * np.cos(phi), r * np.sin(phi), z0 + RING_H / 2], [np.cos(phi / 2), 0, 0, np.sin(phi / 2)]
        )
        tilt = sapien.Pose(q=[np.cos(alpha / 2), 0, np.sin(alpha / 2), 0])
        add_box(builder, [RING_WALL / 2, width / 2, length / 2], turn * tilt, colour)


class LightBulbIn(Task):
    name = "light_bulb_in"
    max_control_steps = 82  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "seen"
    instruction = "screw in the red light bulb"
    phrasings = (  # RLBench's variation-0 phrasings, AGNOSTOS's instruction first
        "screw in the red light bulb",
        "screw the light bulb from the red holder into the lamp",
        "pick up the light bulb from the red stand, lift it up to just above the lamp, then screw "
        "it down into the lamp in a clockwise fashion",
        "put the light bulb from the red casing into the lamp",
    )
    object_names = ("red light bulb", "green light bulb", "lamp")

    def _build_bulb(self, colour: str) -> sapien.Entity:
        b = self.world.scene.create_actor_builder()
        metal = look((0.7, 0.7, 0.68), roughness=0.3, metallic=0.8)
        tint = np.asarray(look(colour).base_color[:3]) * 0.6 + 0.4
        glass = look(tuple(tint), roughness=0.1)
        mat = physical(1.0)
        add_cylinder(b, BASE_R, BASE_H / 2, sapien.Pose([0, 0, BASE_H / 2]), metal, material=mat, density=3000.0)
        add_cylinder(
            b, GLASS_R, GLASS_H / 2, sapien.Pose([0, 0, BASE_H + GLASS_H / 2]), glass, material=mat, density=800.0
        )
        top = sapien.Pose([0, 0, BASE_H + GLASS_H])
        b.add_sphere_collision(top, GLASS_R, material=mat, density=800.0)
        b.add_sphere_visual(top, GLASS_R, material=glass)
        return self.objects.actor(b, f"{colour} light bulb")

    def _build_holder(self, colour: str) -> sapien.Entity:
        b = self.world.scene.create_actor_builder()
        add_cylinder(b, RING_IN + RING_WALL + 0.006, HOLDER_H / 2, sapien.Pose([0, 0, HOLDER_H / 2]), colour)
        add_ring(b, HOLDER_H, colour)
        return self.objects.actor(b, f"{colour} bulb holder", kind="static")

    def _build_lamp(self) -> sapien.Entity:
        b = self.world.scene.create_actor_builder()
        body = (0.2, 0.2, 0.22)
        add_cylinder(b, 0.06, 0.01, sapien.Pose([0, 0, 0.01]), body)
        add_cylinder(b, 0.012, (LAMP_H - 0.02) / 2, sapien.Pose([0, 0, 0.02 + (LAMP_H - 0.02) / 2]), body)
        add_cylinder(b, RING_IN + RING_WALL, 0.004, sapien.Pose([0, 0, LAMP_H - 0.004]), body)
        # the socket funnels the screw base in and holds it upright
        add_ring(b, LAMP_H, (0.75, 0.75, 0.72), r_bottom=SOCKET_BOTTOM, r_top=SOCKET_TOP)
        return self.objects.actor(b, "lamp", kind="static")

    def load(self) -> None:
        self.lamp = self._build_lamp()
        self.holders = [self._build_holder(c) for c in COLOURS]
        self.bulbs = [self._build_bulb(c) for c in COLOURS]

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        variation = int(rng.integers(len(COLOURS)))
        self.variation = variation if sample_variation else 0
        self.episode_instruction = f"screw in the {COLOURS[self.variation]} light bulb"
        self.lamp.set_pose(sapien.Pose([rng.uniform(0.26, 0.32), rng.uniform(-0.05, 0.05), TABLE_TOP_Z]))
        sides = (1.0, -1.0) if rng.random() < 0.5 else (-1.0, 1.0)
        for holder, bulb, side in zip(self.holders, self.bulbs, sides):
            x, y = rng.uniform(0.0, 0.14), side * rng.uniform(0.12, 0.24)
            holder.set_pose(sapien.Pose([x, y, TABLE_TOP_Z]))
            bulb.set_pose(sapien.Pose([x, y, TABLE_TOP_Z + HOLDER_H + 0.0005]))

    def socket_floor(self) -> np.ndarray:
        return np.asarray(self.lamp.pose.p) + [0.0, 0.0, LAMP_H]

    def in_lamp(self, index: int) -> bool:
        bulb = np.asarray(self.bulbs[index].pose.p)
        socket = self.socket_floor()
        upright = self.bulbs[index].pose.to_transformation_matrix()[2, 2] > 0.95
        return bool(upright and np.linalg.norm(bulb[:2] - socket[:2]) < 0.015 and abs(bulb[2] - socket[2]) < 0.008)

    def evaluate(self) -> bool:
        if not self.in_lamp(self.variation):
            return False
        return not (self.grasped() & {b.per_scene_id for b in self.bulbs})

    def demonstration(self):
        bulb = self.bulbs[self.variation]
        q0 = down_quat(0.0)
        grasp = snap_to_grid(np.asarray(bulb.pose.p) + [0, 0, GRIP_Z])
        yield self.key(grasp + [0, 0, 0.10], q0, True)
        yield self.key(grasp, q0, False)
        held = np.asarray(self.world.robot.tcp_pose().p) - np.asarray(bulb.pose.p)  # bulb bottom -> TCP
        socket = self.socket_floor()
        lift = socket[2] + RING_H + 0.04 + held[2]  # bulb bottom 4 cm above the socket's rim
        yield self.key(snap_to_grid([grasp[0], grasp[1], lift]), q0, False)
        above = snap_to_grid([socket[0] + held[0], socket[1] + held[1], lift])
        yield self.key(above, q0, False)
        # measured again over the socket (the bulb may hang a little tilted), then straight down
        held = np.asarray(self.world.robot.tcp_pose().p) - np.asarray(bulb.pose.p)
        above = snap_to_grid([socket[0] + held[0], socket[1] + held[1], lift])
        # screw base pressed onto the socket floor (up to 9 mm further down on the grid: the bulb
        # then slides up in the fingers; it never drops in from above)
        inserted = snap_to_grid([above[0], above[1], socket[2] + held[2] - 0.004])
        yield self.key(inserted, q0, False)
        yield self.key(inserted, q0, True)  # let go (and stay: lifting the open fingers could drag the bulb)
