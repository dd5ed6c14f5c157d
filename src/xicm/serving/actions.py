"""Action chunks as numbers on the wire, and back into xicm's action types.

A server answers {"actions": array (N, D)}: N actions of one control mode of the simulator's
ControlSpec (xicm.core.contracts.spaces: names and widths). The key modes are executed as whole moves
(`Simulator.execute`), per-step modes one control period each (`Simulator.step`, in the
simulator's control_mode). The gripper is the last column; the client maps the server's
open/closed values onto xicm's (core.spaces: 1.0 open, 0.0 closed).
"""

from __future__ import annotations

import numpy as np

from xicm.core.contracts.spaces import GRIPPER_CLOSED, GRIPPER_OPEN, GRIPPER_THRESHOLD, KEY_JOINTS, KEY_POSE, ControlMode
from xicm.core.contracts.types import ControlStep, JointAction, KeyAction

def to_actions(chunk, mode: ControlMode, gripper_open: float = GRIPPER_OPEN, gripper_closed: float = GRIPPER_CLOSED) -> list:
    """The rows of a server's chunk in control `mode` (from the simulator's ControlSpec) as
    KeyAction / JointAction / ControlStep; ValueError (one sentence) for a wrong shape or a value
    that is not finite."""
    width, space = mode.width, mode.name
    arr = np.asarray(chunk, dtype=np.float64)
    if arr.ndim == 1 and arr.shape[0] == width:
        arr = arr[None]  # a single action
    if arr.ndim != 2 or arr.shape[1] != width or arr.shape[0] == 0:
        raise ValueError(f"the server's actions have shape {tuple(np.shape(chunk))}; control mode {space} needs (N, {width}) with N >= 1")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"the server's actions hold NaN or infinite values (row {int(np.argmax(~np.isfinite(arr).all(axis=1)))})")
    # xicm's convention: GRIPPER_OPEN open, GRIPPER_CLOSED closed
    gripper = GRIPPER_CLOSED + (arr[:, -1] - gripper_closed) / (gripper_open - gripper_closed) * (GRIPPER_OPEN - GRIPPER_CLOSED)
    is_open = gripper >= GRIPPER_THRESHOLD
    if space == KEY_POSE:
        return [KeyAction(tuple(r[:3]), tuple(r[3:7]), bool(g)) for r, g in zip(arr, is_open)]
    if space == KEY_JOINTS:
        return [JointAction(tuple(r[:-1]), bool(g)) for r, g in zip(arr, is_open)]
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
        return KEY_POSE, np.asarray(rows, dtype=np.float64)
    if kind is JointAction:
        return KEY_JOINTS, np.asarray([[*a.positions, float(a.gripper_open)] for a in actions], dtype=np.float64)
    if kind is ControlStep:
        return "control", np.asarray([a.values for a in actions], dtype=np.float64)
    raise ValueError(f"cannot send actions of type {kind.__name__}")
