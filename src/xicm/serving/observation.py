"""Observations on the wire: openpi-style request keys, and xicm's whole Observation.

An openpi server reads flat keys chosen by its training config (e.g. "observation/image",
"observation/state", "prompt"); `request_keys` builds them from a mapping. A server that serves
an xicm policy asks at connect for the whole Observation (metadata "xicm": {"observation":
"full"}), sent under "xicm/observation" as plain maps and arrays.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from xicm.core.contracts.types import CameraFrame, KeyAction, Observation

FRAME_FIELDS = ("rgb", "depth", "segmentation", "intrinsic", "cam_to_world")


def resized(rgb: np.ndarray, size: int | None) -> np.ndarray:
    """`rgb` scaled to size x size (bilinear) when it is not already that size."""
    if size is None or rgb.shape[:2] == (size, size):
        return rgb
    from PIL import Image

    return np.asarray(Image.fromarray(rgb).resize((size, size), Image.BILINEAR))


def state_vector(obs: Observation, fields: list[str]) -> np.ndarray:
    """The named proprio fields of `obs`, concatenated in order, as float32."""
    missing = [f for f in fields if f not in obs.proprio]
    if missing:
        raise ValueError(f"the observation has no proprio field {', '.join(missing)}; it has {', '.join(obs.proprio) or 'none'}")
    return np.concatenate([np.ravel(obs.proprio[f]) for f in fields]).astype(np.float32)


def request_keys(obs: Observation, images: dict[str, str], image_size: int | None, state_key: str | None,
                 state_fields: list[str], prompt_key: str | None) -> dict[str, Any]:
    """An openpi-style request: each mapped camera's RGB under its key, the state, the prompt."""
    out: dict[str, Any] = {}
    for camera, key in images.items():
        if camera not in obs.cameras:
            raise ValueError(f"camera '{camera}' is not rendered; the simulator renders {', '.join(obs.cameras)}")
        out[key] = resized(obs.cameras[camera].rgb, image_size)
    if state_key:
        out[state_key] = state_vector(obs, state_fields)
    if prompt_key:
        out[prompt_key] = obs.instruction
    return out


def observation_to_wire(obs: Observation) -> dict[str, Any]:
    cameras = {name: {f: getattr(frame, f) for f in FRAME_FIELDS if getattr(frame, f) is not None}
               for name, frame in obs.cameras.items()}
    g = obs.gripper
    return {
        "instruction": obs.instruction,
        "cameras": cameras,
        "segment_names": [[int(k), v] for k, v in obs.segment_names.items()],  # msgpack maps take string keys
        "object_names": list(obs.object_names),
        "gripper": {"position": list(g.position), "quat_wxyz": list(g.quat_wxyz), "gripper_open": bool(g.gripper_open)},
        "joint_positions": np.asarray(obs.joint_positions),
        "proprio": {k: np.asarray(v) for k, v in obs.proprio.items()},
    }


def observation_from_wire(d: dict[str, Any]) -> Observation:
    cameras = {name: CameraFrame(**{f: (np.array(frame[f]) if f in frame else None) for f in FRAME_FIELDS})
               for name, frame in d["cameras"].items()}
    g = d["gripper"]
    return Observation(
        instruction=d["instruction"],
        cameras=cameras,
        segment_names={int(k): v for k, v in d["segment_names"]},
        object_names=list(d["object_names"]),
        gripper=KeyAction(tuple(g["position"]), tuple(g["quat_wxyz"]), bool(g["gripper_open"])),
        joint_positions=np.array(d["joint_positions"]),
        proprio={k: np.array(v) for k, v in d.get("proprio", {}).items()},
    )
