"""Scene and action text as in AGNOSTOS: a 100^3 voxel grid over the workspace, 72 rotation
bins per Euler axis, 7-integer actions, and the key-frame heuristic on recorded trajectories."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from xicm.core.contracts.types import Box, KeyAction, Trajectory


GRID = 100  # voxels per axis
ROT_BIN_DEG = 5.0
ROT_BINS = 72  # 360 / 5


# ---------------------------------------------------------------- positions
def position_to_voxel(xyz: Sequence[float], workspace: Box) -> tuple[int, int, int]:
    """Voxel index of a point; points outside the box are clipped to the border voxel."""
    low, high = np.asarray(workspace[0], float), np.asarray(workspace[1], float)
    size = (high - low) / GRID
    idx = np.floor((np.asarray(xyz, float) - low) / size).astype(int)
    return tuple(int(v) for v in np.clip(idx, 0, GRID - 1))


def voxel_to_position(voxel: Sequence[int], workspace: Box) -> tuple[float, float, float]:
    """Centre of a voxel in metres."""
    low, high = np.asarray(workspace[0], float), np.asarray(workspace[1], float)
    size = (high - low) / GRID
    return tuple(float(v) for v in low + (np.asarray(voxel, float) + 0.5) * size)


# ---------------------------------------------------------------- rotations
def quat_to_bins(quat_wxyz: Sequence[float]) -> tuple[int, int, int]:
    """Quaternion (w >= 0 after normalising) -> extrinsic xyz Euler degrees -> 72 bins per axis."""
    q = np.asarray(quat_wxyz, float)
    q = q / np.linalg.norm(q)
    if q[0] < 0:
        q = -q
    euler = Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_euler("xyz", degrees=True)
    bins = np.round((euler + 180.0) / ROT_BIN_DEG).astype(int) % ROT_BINS
    return tuple(int(b) for b in bins)


def bins_to_quat(bins: Sequence[int]) -> tuple[float, float, float, float]:
    """Inverse of quat_to_bins up to the 5 degree quantisation; returns w >= 0."""
    euler = (np.asarray(bins, float) % ROT_BINS) * ROT_BIN_DEG - 180.0
    x, y, z, w = Rotation.from_euler("xyz", euler, degrees=True).as_quat()
    q = np.array([w, x, y, z])
    if q[0] < 0:
        q = -q
    return tuple(float(v) for v in q)


# ---------------------------------------------------------------- actions
def action_to_ints(action: KeyAction, workspace: Box) -> list[int]:
    """[x, y, z, roll, pitch, yaw, gripper_open] as 7 integers."""
    return [*position_to_voxel(action.position, workspace), *quat_to_bins(action.quat_wxyz), int(action.gripper_open)]


def ints_to_action(values: Sequence[int], workspace: Box) -> KeyAction:
    """Decode 7 integers; position is the voxel centre, gripper is open for any value >= 1."""
    if len(values) != 7:
        raise ValueError(f"an action has 7 integers, got {len(values)}")
    return KeyAction(
        position=voxel_to_position(values[:3], workspace),
        quat_wxyz=bins_to_quat(values[3:6]),
        gripper_open=bool(values[6] >= 1),
    )


def quantise(action: KeyAction, workspace: Box) -> KeyAction:
    """The action as the LLM would see it: round-trip through the 7-integer text."""
    return ints_to_action(action_to_ints(action, workspace), workspace)


# ---------------------------------------------------------------- anchored actions
# The form `prompt.actions: anchored` writes: each action relative to one of the observation's
# objects, [object, dx, dy, dz, roll, pitch, yaw, gripper_open], where object is the index (0 first)
# of an object in the order the observation lists them and dx, dy, dz the voxel offset from that
# object's voxel. A reply copied from a demo is then the demo's motion moved onto the query's objects.
# An observation that lists no objects anchors on the grid's origin (voxel [0, 0, 0]): object 0.
ANCHORED_ITEMS = 8


def _anchors_or_origin(anchors: Sequence[Sequence[float]], workspace: Box) -> Sequence[Sequence[float]]:
    return anchors if len(anchors) else [workspace[0]]


def nearest_anchor(position: Sequence[float], anchors: Sequence[Sequence[float]]) -> int:
    """Index of the anchor nearest to a point (Euclidean, metres; the first one on a tie)."""
    distances = [float(np.linalg.norm(np.asarray(position, float) - np.asarray(a, float))) for a in anchors]
    return int(np.argmin(distances))


def action_to_anchored_ints(action: KeyAction, anchors: Sequence[Sequence[float]], workspace: Box) -> list[int]:
    """[object, dx, dy, dz, roll, pitch, yaw, gripper_open], anchored on the nearest anchor."""
    anchors = _anchors_or_origin(anchors, workspace)
    index = nearest_anchor(action.position, anchors)
    voxel, anchor = position_to_voxel(action.position, workspace), position_to_voxel(anchors[index], workspace)
    return [index, *(v - a for v, a in zip(voxel, anchor)), *quat_to_bins(action.quat_wxyz), int(action.gripper_open)]


def anchored_to_absolute_ints(values: Sequence[int], anchors: Sequence[Sequence[float]], workspace: Box) -> list[int]:
    """The 7 absolute integers of an anchored action: the object's voxel plus the offset. An object
    index past the anchors wraps (modulo), the rule `nearest_demo` uses when the query lists fewer
    objects than the demo; the voxel may fall off the grid (the caller range-checks it)."""
    if len(values) != ANCHORED_ITEMS:
        raise ValueError(f"an anchored action has {ANCHORED_ITEMS} integers, got {len(values)}")
    anchors = _anchors_or_origin(anchors, workspace)
    if values[0] < 0:
        raise ValueError(f"object index {values[0]} is negative")
    anchor = position_to_voxel(anchors[values[0] % len(anchors)], workspace)
    return [*(a + d for a, d in zip(anchor, values[1:4])), *values[4:8]]


# ---------------------------------------------------------------- text
def format_ints(values: Sequence[int]) -> str:
    return "[" + ", ".join(str(int(v)) for v in values) + "]"


def format_actions(actions: Sequence[KeyAction], workspace: Box, anchors: Sequence[Sequence[float]] | None = None) -> str:
    """'[[x, y, z, r, p, y, g], ...]', or with anchors (metres, in the order the observation lists
    its objects) '[[object, dx, dy, dz, r, p, y, g], ...]' (see "anchored actions")."""
    if anchors is None:
        return "[" + ", ".join(format_ints(action_to_ints(a, workspace)) for a in actions) + "]"
    return "[" + ", ".join(format_ints(action_to_anchored_ints(a, anchors, workspace)) for a in actions) + "]"


def format_objects(objects: dict[str, Sequence[float]], workspace: Box) -> str:
    """'name [x, y, z], name [x, y, z]' with voxel indices, in the given order."""
    return ", ".join(f"{name} {format_ints(position_to_voxel(xyz, workspace))}" for name, xyz in objects.items())


# ---------------------------------------------------------------- key frames
#: key-frame rules: ours never calls frames 0-1 stopped; xicm reads frames i-1 and i-2 as X-ICM's
#: `_is_stopped` does, so for i = 0, 1 they wrap to the end of the trajectory (Python's negative index)
KEYFRAME_RULES = ("ours", "xicm")


def keyframe_indices(
    joint_velocities: np.ndarray, gripper_open: np.ndarray, stopping_delta: float = 0.1, rule: str = "ours"
) -> list[int]:
    """Key frames of a recorded trajectory (the AGNOSTOS/PerAct heuristic).

    Frame i (i > 0) is a key frame when the gripper state changes at i, when i is the last
    frame, or when the arm has stopped: all joint velocities within `stopping_delta` of zero,
    the gripper state unchanged over frames i-2..i+1, i is not the second-to-last frame, and
    at least 4 frames have passed since the previous stop. If the last two key frames are
    adjacent, the second-to-last is dropped.

    rule "xicm" also lets frames 0 and 1 be stopped, their frames i-1, i-2 read from the end of
    the trajectory as X-ICM's code reads them: a stop at frame 1 is a key frame, and a stop at
    frame 0 (never a key frame itself) holds off stops at frames 1-4.
    """
    if rule not in KEYFRAME_RULES:
        raise ValueError(f"key-frame rule '{rule}' is unknown; allowed: {', '.join(KEYFRAME_RULES)}")
    vel = np.asarray(joint_velocities, float)
    grip = np.asarray(gripper_open, bool)
    n = len(grip)
    keys: list[int] = []
    stop_buffer = 0
    for i in range(n):
        stopped = _is_stopped(vel, grip, i, stop_buffer, stopping_delta, wrap=rule == "xicm")
        stop_buffer = 4 if stopped else stop_buffer - 1
        if i == 0:
            continue
        if grip[i] != grip[i - 1] or i == n - 1 or stopped:
            keys.append(i)
    if len(keys) > 1 and keys[-1] - 1 == keys[-2]:
        keys.pop(-2)
    return keys


def _is_stopped(vel: np.ndarray, grip: np.ndarray, i: int, stop_buffer: int, delta: float, wrap: bool = False) -> bool:
    n = len(grip)
    if stop_buffer > 0 or (i < 2 and not wrap) or i >= n - 2:
        return False
    gripper_steady = grip[i] == grip[i + 1] == grip[i - 1] == grip[i - 2]  # i - 1, i - 2 < 0 wrap (rule xicm)
    return bool(gripper_steady and np.allclose(vel[i], 0.0, atol=delta))


def key_actions_from_trajectory(traj: Trajectory, stopping_delta: float = 0.1, rule: str = "ours") -> list[KeyAction]:
    """Key actions (TCP pose + gripper state) at the key frames of a trajectory."""
    actions = []
    for i in keyframe_indices(traj.joint_velocities, traj.gripper_open, stopping_delta, rule):
        pose = traj.ee_poses[i]
        actions.append(
            KeyAction(
                position=tuple(float(v) for v in pose[:3]),
                quat_wxyz=tuple(float(v) for v in pose[3:7]),
                gripper_open=bool(traj.gripper_open[i]),
            )
        )
    return actions
