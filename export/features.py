"""The LeRobot features of an xicm export: names, shapes and dtypes of every column.

Per control step t (one LeRobot frame, `export.frames: control`): each camera's RGB before the
step, the proprio state before the step, the action of the step in every action space
(`action` is the chosen one), and where the step lies in the scripted demo's key actions.

Per key action k (`export.frames: key`, the key-frame datasets RLBench's in-domain policies
train on): the pictures and state before the key action's first control step, and `action`
= the key pose it moves to (world frame) with the gripper state to set there.
"""

from __future__ import annotations

#: the contract's proprio layout (Simulator.proprio()), flattened in this order
STATE_PARTS = {
    "joint_positions": [f"joint_{i}" for i in range(1, 8)],
    "gripper_width": ["gripper_width"],
    "tcp_pose": ["tcp_x", "tcp_y", "tcp_z", "tcp_qw", "tcp_qx", "tcp_qy", "tcp_qz"],
    "gripper_open": ["gripper_open"],
}
STATE_NAMES = [name for names in STATE_PARTS.values() for name in names]

#: the contract's action layouts (gripper last: 1.0 open, 0.0 closed)
ACTION_NAMES = {
    "ee_delta": ["dx", "dy", "dz", "droll", "dpitch", "dyaw", "gripper"],
    "ee_pose": ["x", "y", "z", "qw", "qx", "qy", "qz", "gripper"],
    "joint_pos": [*(f"joint_{i}" for i in range(1, 8)), "gripper"],
    "joint_delta": [*(f"djoint_{i}" for i in range(1, 8)), "gripper"],
}
ACTION_SPACES = tuple(ACTION_NAMES)
#: a key action as the key_pose action space of policy=remote sends it (world frame, metres)
KEY_POSE_NAMES = ["x", "y", "z", "qw", "qx", "qy", "qz", "gripper"]
KEY_ACTION_INT_NAMES = ["x_voxel", "y_voxel", "z_voxel", "roll_bin", "pitch_bin", "yaw_bin", "gripper_open"]


def image_key(camera: str) -> str:
    return f"observation.images.{camera}"


def features(sizes: dict[str, tuple[int, int]], action_space: str, use_videos: bool, frames: str = "control") -> dict[str, dict]:
    """LeRobotDataset.create's `features` for cameras of (height, width) `sizes` (shapes as
    lists: they travel as JSON). With frames "key", `action` is the key pose and the per-step
    columns are left out (`action_space` is then unused)."""
    out: dict[str, dict] = {
        image_key(camera): {
            "dtype": "video" if use_videos else "image",
            "shape": [int(height), int(width), 3],
            "names": ["height", "width", "channels"],
        }
        for camera, (height, width) in sizes.items()
    }
    out["observation.state"] = {"dtype": "float32", "shape": [len(STATE_NAMES)], "names": STATE_NAMES}
    names = KEY_POSE_NAMES if frames == "key" else ACTION_NAMES[action_space]
    out["action"] = {"dtype": "float32", "shape": [len(names)], "names": names}
    if frames == "control":
        for space, names in ACTION_NAMES.items():
            out[f"action.{space}"] = {"dtype": "float32", "shape": [len(names)], "names": names}
    # the key action this step works towards (index into the demo's key actions), its pose and
    # its 7 integers (xicm.core.encoding), and 1 on the step that completes it
    out["key_action.index"] = {"dtype": "int64", "shape": [1], "names": None}
    out["key_action.pose"] = {"dtype": "float32", "shape": [len(KEY_POSE_NAMES)], "names": KEY_POSE_NAMES}
    out["key_action.ints"] = {"dtype": "int64", "shape": [7], "names": KEY_ACTION_INT_NAMES}
    if frames == "control":
        out["key_action.ends_here"] = {"dtype": "int64", "shape": [1], "names": None}
    return out


def staged_column(feature: str, action_space: str, frames: str = "control") -> str:
    """The array of a staged episode that fills `feature` (`action` is the chosen space's
    column, or the key pose for key frames)."""
    if feature != "action":
        return feature
    return "key_action.pose" if frames == "key" else f"action.{action_space}"


def key_frame_rows(key_index) -> list[int]:
    """The control steps that become key frames: each key action's first step (where the
    staged `key_action.index` column changes)."""
    index = [int(i) for i in key_index]
    return [t for t in range(len(index)) if t == 0 or index[t] != index[t - 1]]
