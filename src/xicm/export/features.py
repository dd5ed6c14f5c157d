"""The LeRobot features of an xicm export: names, shapes and dtypes of every column.

Per control step t (one LeRobot frame, `export.frames: control`): each camera's RGB before the
step, the proprio state before the step, the action of the step in every per-step control
mode (`action` is the simulator's control_mode), and where the step lies in the scripted demo's key actions.

Per key action k (`export.frames: key`, the key-frame datasets RLBench's in-domain policies
train on): the pictures and state before the key action's first control step, and `action`
= the key pose it moves to (world frame) with the gripper state to set there.
"""

from __future__ import annotations

from xicm.core.contracts.spaces import KEY_POSE, ControlSpec

#: the 7 integers of a key action (xicm.core.text.encoding)
KEY_ACTION_INT_NAMES = ["x_voxel", "y_voxel", "z_voxel", "roll_bin", "pitch_bin", "yaw_bin", "gripper_open"]


def image_key(camera: str) -> str:
    return f"observation.images.{camera}"


def features(sizes: dict[str, tuple[int, int]], spec: ControlSpec, use_videos: bool, frames: str = "control") -> dict[str, dict]:
    """LeRobotDataset.create's `features` for cameras of (height, width) `sizes` (shapes as
    lists: they travel as JSON), with the state and action columns of the simulator's `spec`.
    With frames "key", `action` is the key pose and the per-step columns are left out."""
    out: dict[str, dict] = {
        image_key(camera): {
            "dtype": "video" if use_videos else "image",
            "shape": [int(height), int(width), 3],
            "names": ["height", "width", "channels"],
        }
        for camera, (height, width) in sizes.items()
    }
    out["observation.state"] = _vector(spec.state_names())
    key_pose = list(spec.mode(KEY_POSE).names)
    out["action"] = _vector(key_pose if frames == "key" else list(spec.step_mode.names))
    if frames == "control":
        for mode in spec.modes:
            if mode.per_step:
                out[f"action.{mode.name}"] = _vector(list(mode.names))
    # the key action this step works towards (index into the demo's key actions), its pose and
    # its 7 integers (xicm.core.text.encoding), and 1 on the step that completes it
    out["key_action.index"] = {"dtype": "int64", "shape": [1], "names": None}
    out["key_action.pose"] = _vector(key_pose)
    out["key_action.ints"] = {"dtype": "int64", "shape": [7], "names": KEY_ACTION_INT_NAMES}
    if frames == "control":
        out["key_action.ends_here"] = {"dtype": "int64", "shape": [1], "names": None}
    return out


def _vector(names: list[str]) -> dict:
    return {"dtype": "float32", "shape": [len(names)], "names": names}


def staged_column(feature: str, control_mode: str, frames: str = "control") -> str:
    """The array of a staged episode that fills `feature` (`action` is the control mode's
    column, or the key pose for key frames)."""
    if feature != "action":
        return feature
    return "key_action.pose" if frames == "key" else f"action.{control_mode}"


def key_frame_rows(key_index) -> list[int]:
    """The control steps that become key frames: each key action's first step (where the
    staged `key_action.index` column changes)."""
    index = [int(i) for i in key_index]
    return [t for t in range(len(index)) if t == 0 or index[t] != index[t - 1]]
