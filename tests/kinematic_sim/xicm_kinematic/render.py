"""Orthographic pictures of the world drawn with numpy: `top` looks down the z axis (x right,
y up the picture), `front` looks along +y (x right, z up). Depth is the distance from the
camera's plane; segmentation ids are SEGMENTS."""

from __future__ import annotations

import numpy as np

from xicm.core.types import CameraFrame

from .world import HALF, WORKSPACE, ZONE_HALF, World

CAMERAS = ("top", "front")
SEGMENTS = {1: "red cube", 2: "green zone"}
TABLE, ZONE, CUBE = (200, 200, 200), (60, 180, 60), (200, 30, 30)
TCP_OPEN, TCP_CLOSED = (30, 30, 220), (10, 10, 90)
#: camera -> (world axes drawn as columns and rows, the axis looked along, the camera plane on it)
VIEWS = {"top": ((0, 1), 2, 0.5), "front": ((0, 2), 1, -0.5)}


def render(world: World, camera: str, size: tuple[int, int]) -> CameraFrame:
    (cu, cv), along, plane = VIEWS[camera]
    h, w = size
    lo, hi = np.asarray(WORKSPACE[0]), np.asarray(WORKSPACE[1])
    # pixel centres -> world coordinates on the two drawn axes (rows run against the second axis)
    us = lo[cu] + (np.arange(w) + 0.5) / w * (hi[cu] - lo[cu])
    vs = hi[cv] - (np.arange(h) + 0.5) / h * (hi[cv] - lo[cv])
    U, V = np.meshgrid(us, vs)
    rgb = np.empty((h, w, 3), np.uint8)
    rgb[:] = TABLE
    seg = np.zeros((h, w), np.int32)
    depth = np.full((h, w), abs(plane), np.float32)  # the table top (z = 0) or the plane y = 0 behind the scene

    def box(centre, half, height_or_depth, colour, sid):
        inside = (np.abs(U - centre[cu]) <= half[0]) & (np.abs(V - centre[cv]) <= half[1])
        rgb[inside], seg[inside], depth[inside] = colour, sid, height_or_depth

    zone_centre = np.array([*world.zone, 0.0])
    if camera == "top":
        box(zone_centre, (ZONE_HALF, ZONE_HALF), plane, ZONE, 2)
        box(world.cube, (HALF, HALF), plane - (world.cube[2] + HALF), CUBE, 1)
    else:
        box(zone_centre, (ZONE_HALF, 0.004), abs(plane) + zone_centre[1] - ZONE_HALF, ZONE, 2)
        box(world.cube, (HALF, HALF), abs(plane) + world.cube[1] - HALF, CUBE, 1)
    tcp = np.hypot(U - world.tcp[cu], V - world.tcp[cv]) <= 1.5 * (hi[cu] - lo[cu]) / w
    rgb[tcp] = TCP_OPEN if world.gripper_open else TCP_CLOSED
    return CameraFrame(rgb=rgb, depth=depth, segmentation=seg, intrinsic=_intrinsic(size, hi - lo, cu, cv),
                       cam_to_world=_pose(camera, plane))


def _intrinsic(size, extent, cu, cv) -> np.ndarray:
    """Pixels per metre on each drawn axis and the principal point (orthographic: no focal length)."""
    h, w = size
    return np.array([[w / extent[cu], 0, w / 2], [0, h / extent[cv], h / 2], [0, 0, 1]], dtype=float)


def _pose(camera: str, plane: float) -> np.ndarray:
    """OpenCV camera frame (x right, y down, z forward) in the world."""
    pose = np.eye(4)
    if camera == "top":
        pose[:3, :3] = [[1, 0, 0], [0, -1, 0], [0, 0, -1]]
        pose[:3, 3] = [0, 0, plane]
    else:
        pose[:3, :3] = [[1, 0, 0], [0, 0, 1], [0, -1, 0]]
        pose[:3, 3] = [0, plane, 0]
    return pose
