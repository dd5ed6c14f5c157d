"""The five RLBench-style cameras and turning their pictures into CameraFrames."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sapien

from xicm.core.contracts.types import CameraFrame

from .options import CAMERA_NAMES, sizes_per_camera

#: SAPIEN cameras look along their local +x with +z up; OpenCV looks along +z with +y down.
_GL_TO_CV = np.diag([1.0, -1.0, -1.0, 1.0])


@dataclass(frozen=True)
class CameraSpec:
    name: str
    eye: tuple[float, float, float]  # world position, or hand-frame position for the wrist camera
    look_at: tuple[float, float, float]
    fovy_deg: float
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    mount: str | None = None  # robot link the camera rides on


DEFAULT_SPECS = {
    "front": CameraSpec("front", (1.35, 0.0, 1.55), (0.1, 0.0, 0.85), 45.0),
    "left_shoulder": CameraSpec("left_shoulder", (-0.45, 0.55, 1.65), (0.25, -0.05, 0.8), 50.0),
    "right_shoulder": CameraSpec("right_shoulder", (-0.45, -0.55, 1.65), (0.25, 0.05, 0.8), 50.0),
    "overhead": CameraSpec("overhead", (0.2, 0.0, 2.25), (0.2, 0.0, 0.75), 50.0, up=(1.0, 0.0, 0.0)),
    # hand frame: +z points out between the fingers, fingers move along +-y
    "wrist": CameraSpec("wrist", (0.08, 0.0, 0.03), (0.0, 0.0, 0.20), 70.0, up=(1.0, 0.0, 0.0), mount="panda_hand"),
}


def look_at_pose(eye, target, up=(0.0, 0.0, 1.0)) -> sapien.Pose:
    """Pose of a SAPIEN camera at `eye` looking at `target` (x forward, y left, z up)."""
    eye, target, up = (np.asarray(v, dtype=float) for v in (eye, target, up))
    forward = target - eye
    forward /= np.linalg.norm(forward)
    left = np.cross(up, forward)
    if np.linalg.norm(left) < 1e-6:  # up parallel to the viewing direction
        left = np.cross([1.0, 0.0, 0.0], forward)
    left /= np.linalg.norm(left)
    true_up = np.cross(forward, left)
    mat = np.eye(4)
    mat[:3, :3] = np.stack([forward, left, true_up], axis=1)
    mat[:3, 3] = eye
    return sapien.Pose(mat)


class Cameras:
    """Creates the cameras in a scene and captures CameraFrames from them."""

    def __init__(
        self, scene: sapien.Scene, names, image_size, robot_links: dict[str, object], near=0.01, far=5.0,
        depth: bool = True, segmentation: bool = True,
    ):
        self.scene = scene
        self.depth, self.segmentation = bool(depth), bool(segmentation)
        self.cameras: dict[str, sapien.render.RenderCameraComponent] = {}
        for name in names:
            if name not in DEFAULT_SPECS:
                raise ValueError(f"unknown camera '{name}'; available: {', '.join(CAMERA_NAMES)}")
        self.sizes = sizes_per_camera(image_size, names)
        for name in names:
            height, width = self.sizes[name]
            spec = DEFAULT_SPECS[name]
            pose = look_at_pose(spec.eye, spec.look_at, spec.up)
            fovy = np.deg2rad(spec.fovy_deg)
            if spec.mount is None:
                cam = scene.add_camera(name, width, height, fovy, near, far)
                cam.entity.set_pose(pose)
            else:
                mount = robot_links[spec.mount].entity
                cam = scene.add_mounted_camera(name, mount, pose, width, height, fovy, near, far)
            self.cameras[name] = cam

    def capture(self, names=None) -> dict[str, CameraFrame]:
        """Render (the scene must have had update_render() called) and read the pictures."""
        frames = {}
        unknown = [n for n in names or () if n not in self.cameras]
        if unknown:
            raise ValueError(f"no camera {', '.join(map(repr, unknown))}; cameras: {', '.join(self.cameras)}")
        for name in names or self.cameras:
            cam = self.cameras[name]
            cam.take_picture()
            color = cam.get_picture("Color")  # (H, W, 4) float in [0, 1]
            rgb = (np.clip(color[..., :3], 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
            depth = seg = None
            if self.depth:
                position = cam.get_picture("Position")  # (H, W, 4): OpenGL camera xyz, depth-buffer value
                depth = (-position[..., 2]).astype(np.float32)
                depth[position[..., 3] >= 1.0] = 0.0
                depth[depth < 0] = 0.0
            if self.segmentation:
                seg = cam.get_picture("Segmentation")[..., 1].astype(np.int32)  # [..., 1] is the entity id
            # SAPIEN puts the principal point at W/2 with pixel u covering [u, u + 1); OpenCV
            # puts pixel u's centre at coordinate u, so shift the principal point by half a pixel
            intrinsic = np.asarray(cam.get_intrinsic_matrix(), dtype=np.float64).copy()
            intrinsic[0, 2] -= 0.5
            intrinsic[1, 2] -= 0.5
            frames[name] = CameraFrame(
                rgb=rgb,
                depth=depth,
                segmentation=seg,
                intrinsic=intrinsic,
                cam_to_world=np.asarray(cam.get_model_matrix(), dtype=np.float64) @ _GL_TO_CV,
            )
        return frames
