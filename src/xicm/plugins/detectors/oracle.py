"""Oracle detector: object centres from the simulator's segmentation masks and depth.

For every requested name, the pixels whose segmentation id maps to that name
(`Observation.segment_names`) are back-projected with the camera's depth, intrinsic and
cam_to_world (OpenCV convention: x right, y down, z forward; pixel (u, v) has its centre
at column u, row v) into world points. Each camera contributes the mean of its points;
the object centre is the mean over the cameras that see it (the AGNOSTOS/X-ICM rule).
Simulator poses are never used, only what the cameras saw. Names no camera sees are
left out of the result.

Options:
    cameras: list of camera names to use, or None for all cameras of the observation.
    min_pixels: a camera "sees" an object when at least this many valid pixels hit it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import List, Optional

import numpy as np

from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.interfaces import Detector
from xicm.core.contracts.schema import at_least, rule
from xicm.core.contracts.types import CameraFrame, Observation

#: which cameras a detector may use (their names are the simulator's, checked when it observes)
CAMERAS = rule(lambda v: len(v) > 0 and len(set(v)) == len(v), "a non-empty list of distinct camera names")


@dataclass
class OracleOptions:
    cameras: Optional[List[str]] = field(default=None, metadata=CAMERAS)
    min_pixels: int = field(default=1, metadata=at_least(1))


def backproject(frame: CameraFrame, mask: np.ndarray) -> np.ndarray:
    """World points (n, 3) of the masked pixels that have a valid depth."""
    depth = np.asarray(frame.depth, dtype=np.float64)
    valid = mask & np.isfinite(depth) & (depth > 0)
    v, u = np.nonzero(valid)
    if len(u) == 0:
        return np.zeros((0, 3))
    z = depth[v, u]
    k = np.asarray(frame.intrinsic, dtype=np.float64)
    fx, fy, cx, cy, skew = k[0, 0], k[1, 1], k[0, 2], k[1, 2], k[0, 1]
    y = (v - cy) / fy * z
    x = ((u - cx) - skew * (v - cy) / fy) / fx * z
    cam = np.stack([x, y, z], axis=1)
    pose = np.asarray(frame.cam_to_world, dtype=np.float64)
    return cam @ pose[:3, :3].T + pose[:3, 3]


class OracleDetector(Detector):
    """Object centres from ground-truth segmentation + depth (no simulator poses)."""

    def __init__(self, options: OracleOptions | None = None):
        o = options if options is not None else OracleOptions()
        self.cameras = None if o.cameras is None else list(o.cameras)
        self.min_pixels = o.min_pixels

    def _frames(self, obs: Observation) -> list[CameraFrame]:
        if self.cameras is None:
            return list(obs.cameras.values())
        missing = [c for c in self.cameras if c not in obs.cameras]
        if missing:
            raise KeyError(
                f"oracle detector: camera(s) {', '.join(missing)} not in the observation; "
                f"available: {', '.join(obs.cameras) or 'none'}"
            )
        return [obs.cameras[c] for c in self.cameras]

    def detect(self, obs: Observation, names: list[str]) -> dict[str, tuple[float, float, float]]:
        ids_by_name: dict[str, list[int]] = {}
        for seg_id, name in obs.segment_names.items():
            ids_by_name.setdefault(name, []).append(int(seg_id))
        wanted = [n for n in dict.fromkeys(names) if n in ids_by_name]
        sums: dict[str, list[np.ndarray]] = {n: [] for n in wanted}
        for frame in self._frames(obs):
            seg = np.asarray(frame.segmentation)
            for name in wanted:
                mask = np.isin(seg, ids_by_name[name])
                if np.count_nonzero(mask) < self.min_pixels:
                    continue
                points = backproject(frame, mask)
                if len(points) >= self.min_pixels:
                    sums[name].append(points.mean(axis=0))
        result = {}
        for name in wanted:  # request order
            if sums[name]:
                centre = np.mean(sums[name], axis=0)
                result[name] = (float(centre[0]), float(centre[1]), float(centre[2]))
        return result


@hookimpl
def register_detectors(register):
    register("oracle", OracleDetector, options=OracleOptions)
