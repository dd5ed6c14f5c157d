"""The kinematic world's tasks: where cube and zone start, what success is, and the scripted
solution (key poses computed from the true state, one at a time)."""

from __future__ import annotations

import numpy as np

from xicm.core.contracts.types import KeyAction

from .world import HALF, World

DOWN = (1.0, 0.0, 0.0, 0.0)  # a point TCP has no orientation: key poses carry the identity
ABOVE = 0.12  # m: travel height, clear of the cube
MIN_SEPARATION = 0.12  # m between the cube's and the zone's centres


def sample_world(rng: np.random.Generator) -> World:
    cube = rng.uniform(-0.12, 0.12, size=2)
    while True:
        zone = rng.uniform(-0.18, 0.18, size=2)
        if np.linalg.norm(zone - cube) >= MIN_SEPARATION:
            return World(cube, zone)


def key(xy, z: float, open_: bool) -> KeyAction:
    return KeyAction((float(xy[0]), float(xy[1]), float(z)), DOWN, open_)


class CubeTask:
    object_names = ("red cube", "green zone")
    max_control_steps = 200


class PushCubeToZone(CubeTask):
    split = "seen"
    instruction = "push the red cube into the green zone"

    @staticmethod
    def success(world: World) -> bool:
        return world.cube_in_zone()

    @staticmethod
    def solution(world: World):
        """Behind the cube (seen from the zone), down to the table, then push the cube's centre onto the zone's."""
        d = world.zone - world.cube[:2]
        d /= np.linalg.norm(d)
        behind = world.cube[:2] - d * (HALF + 0.03)
        yield key(behind, ABOVE, True)
        yield key(behind, HALF, True)
        yield key(world.zone - d * HALF, HALF, True)
        yield key(world.tcp[:2], ABOVE, True)


class PickCubeToZone(CubeTask):
    split = "level1"
    instruction = "pick up the red cube and put it in the green zone"

    @staticmethod
    def success(world: World) -> bool:
        return world.lifted and world.cube_in_zone()

    @staticmethod
    def solution(world: World):
        """Above the cube, down around it and close, lift, over the zone, down and open."""
        yield key(world.cube[:2], ABOVE, True)
        yield key(world.cube[:2], world.cube[2], False)
        yield key(world.cube[:2], ABOVE, False)
        yield key(world.zone, ABOVE, False)
        yield key(world.zone, 2 * HALF, True)
        yield key(world.zone, ABOVE, True)


TASKS = {"push_cube_to_zone": PushCubeToZone, "pick_cube_to_zone": PickCubeToZone}
