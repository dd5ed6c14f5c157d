"""Pinhole pictures of the world ray-cast with numpy: every object is an axis-aligned box (the
table, the zone, the cube, the TCP's fingertip), each pixel shows the nearest box its ray hits.
Depth is along the optical axis and segmentation ids are SEGMENTS, so the oracle detector
back-projects them as it does SAPIEN's."""

from __future__ import annotations

import numpy as np

from xicm.core.contracts.types import CameraFrame

from .world import HALF, ZONE_HALF, World

#: camera -> (eye, the point it looks at, the world direction that is up in the picture)
CAMERAS = {"top": ((0.0, 0.0, 0.9), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
           "front": ((0.0, -0.75, 0.45), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))}
HALF_FOV = np.arctan(0.4 / 0.9)  # the top camera sees 0.8 m of table across
SEGMENTS = {1: "red cube", 2: "green zone"}
TIP = 0.008  # m: half side of the box drawn at the TCP
TABLE_RGB, ZONE_RGB, CUBE_RGB = (200, 200, 200), (60, 180, 60), (200, 30, 30)
TIP_OPEN_RGB, TIP_CLOSED_RGB = (30, 30, 220), (10, 10, 90)


def boxes(world: World) -> list[tuple[np.ndarray, np.ndarray, tuple[int, int, int], int]]:
    """(low corner, high corner, colour, segmentation id) of everything drawn."""
    zone = np.array([*world.zone, 0.0])
    return [
        (np.array([-0.6, -0.6, -0.05]), np.array([0.6, 0.6, 0.0]), TABLE_RGB, 0),
        (zone - [ZONE_HALF, ZONE_HALF, 0.0], zone + [ZONE_HALF, ZONE_HALF, 0.001], ZONE_RGB, 2),
        (world.cube - HALF, world.cube + HALF, CUBE_RGB, 1),
        (world.tcp - TIP, world.tcp + TIP, TIP_OPEN_RGB if world.gripper_open else TIP_CLOSED_RGB, 0),
    ]


def camera_pose(camera: str) -> np.ndarray:
    """The camera's frame in the world, OpenCV convention (x right, y down, z forward)."""
    eye, target, up = (np.asarray(v, dtype=float) for v in CAMERAS[camera])
    z = (target - eye) / np.linalg.norm(target - eye)
    x = np.cross(z, up)
    x /= np.linalg.norm(x)
    pose = np.eye(4)
    pose[:3, :3] = np.stack([x, np.cross(z, x), z], axis=1)
    pose[:3, 3] = eye
    return pose


def intrinsic(size: tuple[int, int]) -> np.ndarray:
    h, w = size
    f = (w / 2) / np.tan(HALF_FOV)
    return np.array([[f, 0.0, (w - 1) / 2], [0.0, f, (h - 1) / 2], [0.0, 0.0, 1.0]])


def render(world: World, camera: str, size: tuple[int, int]) -> CameraFrame:
    h, w = size
    k, pose = intrinsic(size), camera_pose(camera)
    v, u = np.mgrid[0:h, 0:w].astype(float)
    rays = np.stack([(u - k[0, 2]) / k[0, 0], (v - k[1, 2]) / k[1, 1], np.ones_like(u)], axis=-1) @ pose[:3, :3].T
    origin = pose[:3, 3]
    depth = np.full((h, w), np.inf)  # the ray parameter equals the depth: each ray's camera z is 1
    rgb = np.zeros((h, w, 3), np.uint8)
    seg = np.zeros((h, w), np.int32)
    with np.errstate(divide="ignore", invalid="ignore"):
        for lo, hi, colour, sid in boxes(world):
            t1, t2 = (lo - origin) / rays, (hi - origin) / rays
            near = np.minimum(t1, t2)
            t_in, t_out = np.nanmax(near, axis=-1), np.nanmin(np.maximum(t1, t2), axis=-1)
            hit = (t_out >= t_in) & (t_in > 0) & (t_in < depth)
            shade = np.where(np.argmax(near, axis=-1) == 2, 1.0, 0.75)[..., None]  # tops brighter than sides
            rgb[hit] = (np.asarray(colour) * shade[hit]).astype(np.uint8)
            depth[hit], seg[hit] = t_in[hit], sid
    depth[~np.isfinite(depth)] = 0.0
    return CameraFrame(rgb=rgb, depth=depth.astype(np.float32), segmentation=seg, intrinsic=k, cam_to_world=pose)
