"""The SAPIEN plugin's ControlSpec (xicm.core.contracts.spaces): every control mode and the proprio layout,
with names and bounds, declared here once (control_modes.py has the modes' maths)."""

from __future__ import annotations

import numpy as np

from xicm.core.contracts.spaces import GRIPPER_CLOSED, GRIPPER_OPEN, KEY_JOINTS, ControlSpec, key_pose_mode, layout

ARM = [f"joint_{i}" for i in range(1, 8)]
#: per-step mode -> (column names, doc); the gripper is the last column of each
STEP_MODES = {
    "ee_delta": (["dx", "dy", "dz", "droll", "dpitch", "dyaw", "gripper"],
                 "TCP deltas (m; rad, extrinsic x-y-z about the base axes) applied to the measured TCP pose"),
    "ee_pose": (["x", "y", "z", "qw", "qx", "qy", "qz", "gripper"], "a TCP pose target (m, robot base frame)"),
    "joint_pos": ([*ARM, "gripper"], "the 7 arm joint targets (rad)"),
    "joint_delta": ([f"djoint_{i}" for i in range(1, 8)] + ["gripper"], "7 deltas added to the measured arm joints (rad)"),
}
#: per-step bounds of the delta modes (the simulator takes any finite value): metres, radians
EE_DELTA_BOUND = (0.05, 0.25)
JOINT_DELTA_BOUND = 0.2
#: the proprio layout of SapienSimulator.proprio(), in order
STATE = {
    "joint_positions": (ARM, "measured arm joints (rad)"),
    "gripper_width": (["gripper_width"], "distance between the fingers (m)"),
    "tcp_pose": (["tcp_x", "tcp_y", "tcp_z", "tcp_qw", "tcp_qx", "tcp_qy", "tcp_qz"], "TCP pose, robot base frame"),
    "gripper_open": (["gripper_open"], "1 open, 0 closed (the last command)"),
}


def control_spec(qlimits: np.ndarray, base_xyz, workspace, control_mode: str, control_hz: float) -> ControlSpec:
    """The spec of a Panda with arm joint limits `qlimits` (7, 2) standing at `base_xyz`, whose
    key poses lie in `workspace` (world frame)."""
    lo_q, hi_q = np.asarray(qlimits)[:, 0], np.asarray(qlimits)[:, 1]
    (wlo, whi), base = (np.asarray(v, dtype=float) for v in workspace), np.asarray(base_xyz, dtype=float)
    lin, ang = EE_DELTA_BOUND
    step_bounds = {
        "ee_delta": ([-lin] * 3 + [-ang] * 3, [lin] * 3 + [ang] * 3),
        "ee_pose": ([*(wlo - base), -1, -1, -1, -1], [*(whi - base), 1, 1, 1, 1]),
        "joint_pos": (lo_q, hi_q),
        "joint_delta": ([-JOINT_DELTA_BOUND] * 7, [JOINT_DELTA_BOUND] * 7),
    }
    modes = [
        layout(name, names, [*step_bounds[name][0], GRIPPER_CLOSED], [*step_bounds[name][1], GRIPPER_OPEN], doc, per_step=True)
        for name, (names, doc) in STEP_MODES.items()
    ]
    modes += [
        key_pose_mode(workspace),
        layout(KEY_JOINTS, [*ARM, "gripper"], [*lo_q, GRIPPER_CLOSED], [*hi_q, GRIPPER_OPEN],
               "arm joint targets (rad) to move to in a straight joint-space line, then the gripper", per_step=False),
    ]
    state_bounds = {  # joint limits, finger travel, 2 m around the base, a gripper flag
        "joint_positions": (lo_q - 0.1, hi_q + 0.1),
        "gripper_width": ([0.0], [0.1]),
        "tcp_pose": ([-2.0] * 3 + [-1.0] * 4, [2.0] * 3 + [1.0] * 4),
        "gripper_open": ([0.0], [1.0]),
    }
    state = tuple(layout(name, names, *state_bounds[name], doc) for name, (names, doc) in STATE.items())
    return ControlSpec(modes=tuple(modes), state=state, control_mode=control_mode, control_hz=float(control_hz))
