"""Action chunks as numbers on the wire, and back into xicm's action types.

A server answers {"actions": array (N, D)}: N actions of one action space. Key-action spaces
are executed as whole moves (`Simulator.execute`), per-step spaces one control period each
(`Simulator.step`, in the simulator's control_mode). The gripper is the last column; the
client maps the server's open/closed values onto xicm's 1.0 = open, 0.0 = closed.
"""

from __future__ import annotations

import numpy as np

from xicm.core.types import ControlStep, JointAction, KeyAction

#: action space -> columns per action
ACTION_SPACES = {
    "key_pose": 8,  # a key pose: x, y, z (m, world frame), qw, qx, qy, qz, gripper
    "key_joints": 8,  # a key joint target: 7 arm joints (rad), gripper
    "ee_delta": 7,  # per step: dx, dy, dz, droll, dpitch, dyaw, gripper
    "ee_pose": 8,  # per step: x, y, z, qw, qx, qy, qz, gripper
    "joint_pos": 8,  # per step: 7 arm joint targets, gripper
    "joint_delta": 8,  # per step: 7 arm joint deltas, gripper
}
KEY_SPACES = ("key_pose", "key_joints")


def to_actions(chunk, space: str, gripper_open: float = 1.0, gripper_closed: float = 0.0) -> list:
    """The rows of a server's chunk as KeyAction / JointAction / ControlStep; ValueError (one
    sentence) for a wrong shape or a value that is not finite."""
    width = ACTION_SPACES[space]
    arr = np.asarray(chunk, dtype=np.float64)
    if arr.ndim == 1 and arr.shape[0] == width:
        arr = arr[None]  # a single action
    if arr.ndim != 2 or arr.shape[1] != width or arr.shape[0] == 0:
        raise ValueError(f"the server's actions have shape {tuple(np.shape(chunk))}; action space {space} needs (N, {width}) with N >= 1")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"the server's actions hold NaN or infinite values (row {int(np.argmax(~np.isfinite(arr).all(axis=1)))})")
    gripper = (arr[:, -1] - gripper_closed) / (gripper_open - gripper_closed)  # xicm: 1 open, 0 closed
    if space == "key_pose":
        return [KeyAction(tuple(r[:3]), tuple(r[3:7]), bool(g >= 0.5)) for r, g in zip(arr, gripper)]
    if space == "key_joints":
        return [JointAction(tuple(r[:7]), bool(g >= 0.5)) for r, g in zip(arr, gripper)]
    return [ControlStep(tuple(r[:-1]) + (float(g),)) for r, g in zip(arr, gripper)]


def from_actions(actions: list) -> tuple[str, np.ndarray]:
    """A policy's actions (all of one kind) as (action space, float32 chunk) for the wire; per-step
    actions are sent in the space the serving simulator steps in, named by the caller."""
    kinds = {type(a) for a in actions}
    if len(kinds) != 1:
        raise ValueError(f"a reply mixes action kinds ({', '.join(sorted(k.__name__ for k in kinds))}); send one kind per reply")
    kind = kinds.pop()
    if kind is KeyAction:
        rows = [[*a.position, *a.quat_wxyz, float(a.gripper_open)] for a in actions]
        return "key_pose", np.asarray(rows, dtype=np.float64)
    if kind is JointAction:
        return "key_joints", np.asarray([[*a.positions, float(a.gripper_open)] for a in actions], dtype=np.float64)
    if kind is ControlStep:
        return "control", np.asarray([a.values for a in actions], dtype=np.float64)
    raise ValueError(f"cannot send actions of type {kind.__name__}")
