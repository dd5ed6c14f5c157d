"""The per-step action spaces of `SapienSimulator.step` and their maths, shared by the simulator,
the Gymnasium env and the dataset exporter (names and bounds: spec.py). Layouts (float vectors, gripper last: 1.0 open,
0.0 closed, threshold 0.5); poses are in the robot base frame, quaternions w, x, y, z:

    ee_delta    (7)  dx, dy, dz (m), droll, dpitch, dyaw (rad, extrinsic x-y-z about the base
                     axes), applied to the current measured TCP pose; gripper
    ee_pose     (8)  x, y, z, qw, qx, qy, qz; gripper
    joint_pos   (8)  the 7 arm joint targets (rad); gripper
    joint_delta (8)  7 deltas added to the current measured arm joints; gripper
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial.transform import Rotation

from xicm.core.contracts.spaces import GRIPPER_THRESHOLD

from .options import CONTROL_MODES
from .spec import STEP_MODES

if TYPE_CHECKING:
    from xicm.core.contracts.types import ControlRecording

ACTION_DIMS = {mode: len(names) for mode, (names, _doc) in STEP_MODES.items()}


def check_mode(mode: str) -> str:
    if mode not in ACTION_DIMS:
        raise ValueError(f"unknown control mode {mode!r}; available: {', '.join(CONTROL_MODES)}")
    return mode


def parse(mode: str, action) -> tuple[np.ndarray | None, str | None]:
    """The action as a float vector, or None and one sentence saying what is wrong with it."""
    dim = ACTION_DIMS[check_mode(mode)]
    try:
        values = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError):
        return None, f"an action in control mode {mode} must be {dim} numbers, not a {type(action).__name__}"
    if values.shape != (dim,):
        return None, f"an action in control mode {mode} must have shape ({dim},), got {values.shape}"
    if not np.all(np.isfinite(values)):
        bad = [int(i) for i in np.nonzero(~np.isfinite(values))[0]]
        return None, f"the {mode} action has NaN or infinite values at index(es) {bad}"
    return values, None


def gripper_open(values: np.ndarray) -> bool:
    return bool(values[-1] >= GRIPPER_THRESHOLD)


# ------------------------------------------------------------------ poses
def to_scipy(quat_wxyz) -> Rotation:
    w, x, y, z = np.asarray(quat_wxyz, dtype=np.float64)
    return Rotation.from_quat([x, y, z, w])


def to_wxyz(rot: Rotation) -> np.ndarray:
    x, y, z, w = rot.as_quat()
    q = np.array([w, x, y, z])
    return -q if q[0] < 0 else q


def target_pose(mode: str, values: np.ndarray, tcp_pose: np.ndarray) -> np.ndarray:
    """TCP target (xyz + wxyz, base frame) of an ee action, given the current TCP pose (same layout)."""
    if mode == "ee_pose":
        q = values[3:7]
        if np.linalg.norm(q) < 1e-9:
            raise ValueError("the ee_pose action's quaternion has zero length")
        return np.concatenate([values[:3], to_wxyz(to_scipy(q / np.linalg.norm(q)))])
    rot = Rotation.from_euler("xyz", values[3:6]) * to_scipy(tcp_pose[3:7])
    return np.concatenate([tcp_pose[:3] + values[:3], to_wxyz(rot)])


def joint_target(mode: str, values: np.ndarray, joints: np.ndarray) -> np.ndarray:
    """Arm joint target of a joint action, given the current measured arm joints."""
    return values[:7].copy() if mode == "joint_pos" else joints + values[:7]


# ------------------------------------------------------------------ recordings
def actions(recording: ControlRecording, mode: str) -> np.ndarray:
    """(T, D) actions that replay `recording` through step() in `mode`: action t leads from
    state t to the targets commanded at state t + 1 (the end of control period t)."""
    check_mode(mode)
    grip = recording.gripper_commands[1:, None].astype(np.float64)
    if mode == "joint_pos":
        arm = recording.joint_targets[1:]
    elif mode == "joint_delta":
        arm = recording.joint_targets[1:] - recording.proprio["joint_positions"][:-1]
    elif mode == "ee_pose":
        arm = recording.tcp_targets[1:]
    else:
        now, goal = recording.proprio["tcp_pose"][:-1], recording.tcp_targets[1:]
        turn = to_scipy_many(goal[:, 3:]) * to_scipy_many(now[:, 3:]).inv()
        arm = np.concatenate([goal[:, :3] - now[:, :3], turn.as_euler("xyz")], axis=1)
    return np.concatenate([arm, grip], axis=1)


def to_scipy_many(quats_wxyz: np.ndarray) -> Rotation:
    q = np.asarray(quats_wxyz, dtype=np.float64)
    return Rotation.from_quat(q[:, [1, 2, 3, 0]])
