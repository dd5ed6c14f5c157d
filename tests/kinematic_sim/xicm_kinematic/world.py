"""The kinematic world: a point TCP with a gripper, one cube and a target zone on a table at z = 0.

No dynamics: the TCP moves in straight lines of at most SUBSTEP metres; a closed gripper inside
the cube holds it (the cube then moves with the TCP); an open one drops it onto the table; a TCP
below the cube's top and inside its footprint pushes it along with its own horizontal motion.
"""

from __future__ import annotations

import numpy as np

WORKSPACE = ((-0.3, -0.3, 0.0), (0.3, 0.3, 0.3))
HALF = 0.02  # the cube's half side (m)
ZONE_HALF = 0.05  # the target zone's half side (m)
HOME = (0.0, 0.0, 0.2)
SUBSTEP = 0.005  # m: contact is tested this often along a move
PUSHER_RADIUS = 0.005  # m: how far from the cube's side the TCP touches it
FINGER_OPEN_WIDTH = 0.08  # m


class World:
    def __init__(self, cube_xy, zone_xy):
        self.tcp = np.array(HOME, dtype=float)
        self.gripper_open = True
        self.cube = np.array([cube_xy[0], cube_xy[1], HALF], dtype=float)
        self.zone = np.array(zone_xy, dtype=float)
        self.held = False
        self.lifted = False  # the cube has been off the table (what pick_cube_to_zone asks for)
        self._offset = np.zeros(3)

    def move(self, target) -> None:
        """Straight to `target` in substeps, carrying or pushing the cube on the way."""
        target = np.asarray(target, dtype=float)
        n = max(1, int(np.ceil(np.linalg.norm(target - self.tcp) / SUBSTEP)))
        start = self.tcp.copy()
        for i in range(1, n + 1):
            new = target.copy() if i == n else start + (target - start) * (i / n)
            delta, self.tcp = new - self.tcp, new
            if self.held:
                self.cube = self.tcp + self._offset
                self.lifted |= bool(self.cube[2] > HALF + 0.01)
            elif self._touches():
                self.cube[:2] += delta[:2]

    def _touches(self) -> bool:
        reach = HALF + PUSHER_RADIUS
        return bool(self.tcp[2] < self.cube[2] + HALF and np.all(np.abs(self.tcp[:2] - self.cube[:2]) < reach))

    def set_gripper(self, open_: bool) -> None:
        """Closing inside the cube grasps it; opening drops a held cube onto the table."""
        if open_ and self.held:
            self.held = False
            self.cube[2] = HALF
        elif not open_ and self.gripper_open and np.all(np.abs(self.tcp - self.cube) < HALF):
            self.held, self._offset = True, self.cube - self.tcp
        self.gripper_open = bool(open_)

    def gripper_width(self) -> float:
        if self.gripper_open:
            return FINGER_OPEN_WIDTH
        return 2 * HALF if self.held else 0.0

    def cube_in_zone(self) -> bool:
        on_table = not self.held and abs(self.cube[2] - HALF) < 1e-9
        return on_table and bool(np.all(np.abs(self.cube[:2] - self.zone) <= ZONE_HALF))
