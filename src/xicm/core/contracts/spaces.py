"""The one declaration of a simulator's action and state layouts (`Simulator.control_spec()`).

A simulator plugin fills a ControlSpec from its own robot and options; the Gymnasium env (its
spaces), the LeRobot export (its features), the remote policy and the policy servers (the width
and meaning of an action chunk) all read it, so a layout is written once, in the plugin.
Modelled on LeRobot's `features` and ManiSkill's controller-derived action spaces.

A control mode names one action layout (a float vector, gripper last). Per-step modes are
played by `Simulator.step`, one control period each; the key modes `key_pose` and `key_joints`
are played by `Simulator.execute` as whole moves (KeyAction / JointAction).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: the gripper column (the last one of every control mode): 1.0 open, 0.0 closed, open from 0.5
GRIPPER_OPEN = 1.0
GRIPPER_CLOSED = 0.0
GRIPPER_THRESHOLD = 0.5
#: the modes `execute` plays: a key pose (x y z qw qx qy qz gripper, world frame) -> KeyAction;
#: arm joint targets and the gripper -> JointAction
KEY_POSE, KEY_JOINTS = "key_pose", "key_joints"
KEY_MODES = (KEY_POSE, KEY_JOINTS)
KEY_POSE_NAMES = ("x", "y", "z", "qw", "qx", "qy", "qz", "gripper")


@dataclass(frozen=True)
class Layout:
    """A named float vector: one name and one (low, high) bound per column. Bounds are what
    exploration and normalisation should assume, not limits the simulator enforces."""

    name: str
    names: tuple[str, ...]
    low: tuple[float, ...]
    high: tuple[float, ...]
    doc: str = ""

    def __post_init__(self) -> None:
        if not (len(self.names) == len(self.low) == len(self.high)):
            raise ValueError(f"layout {self.name}: {len(self.names)} names but {len(self.low)} / {len(self.high)} bounds")

    @property
    def width(self) -> int:
        return len(self.names)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) as float32 arrays."""
        return np.asarray(self.low, dtype=np.float32), np.asarray(self.high, dtype=np.float32)


@dataclass(frozen=True)
class ControlMode(Layout):
    per_step: bool = True  # played by step(); False: by execute() (KEY_MODES)


def layout(name: str, names, low, high, doc: str = "", **extra) -> Layout | ControlMode:
    """A Layout (or a ControlMode when `per_step` is given) from any sequences of numbers."""
    cls = ControlMode if extra else Layout
    return cls(name, tuple(str(n) for n in names), tuple(float(v) for v in low), tuple(float(v) for v in high), doc, **extra)


def key_pose_mode(workspace) -> ControlMode:
    """The key_pose mode of a simulator whose key poses lie in `workspace` (low xyz, high xyz)."""
    lo, hi = (np.asarray(v, dtype=float) for v in workspace)
    return layout(KEY_POSE, KEY_POSE_NAMES, [*lo, -1, -1, -1, -1, GRIPPER_CLOSED], [*hi, 1, 1, 1, 1, GRIPPER_OPEN],
                  "a key pose to move to (m, world frame; quaternion w x y z), then the gripper", per_step=False)


@dataclass(frozen=True)
class ControlSpec:
    """What a simulator accepts and reports: its control modes, the one `step` plays, the
    control rate, and the proprio layout of `Observation.proprio` / `Simulator.proprio()`."""

    modes: tuple[ControlMode, ...]
    state: tuple[Layout, ...]  # proprio fields, in this order when flattened
    control_mode: str | None = None  # the per-step mode step() plays (None: no per-step control)
    control_hz: float | None = None  # control steps per second of simulated time

    def mode(self, name: str) -> ControlMode:
        """The mode called `name`; ValueError (one sentence) naming the available ones otherwise."""
        for m in self.modes:
            if m.name == name:
                return m
        raise ValueError(f"unknown control mode {name!r}; available: {', '.join(self.mode_names())}")

    def mode_names(self, per_step: bool | None = None) -> list[str]:
        """Every mode's name, or only the per-step (True) or key (False) ones."""
        return [m.name for m in self.modes if per_step is None or m.per_step == per_step]

    @property
    def step_mode(self) -> ControlMode:
        """The mode step() plays."""
        if self.control_mode is None:
            raise ValueError("this simulator has no per-step control")
        return self.mode(self.control_mode)

    def field(self, name: str) -> Layout:
        for f in self.state:
            if f.name == name:
                return f
        raise ValueError(f"unknown proprio field {name!r}; available: {', '.join(f.name for f in self.state)}")

    def state_names(self, fields=None) -> list[str]:
        """Column names of the flattened state (all fields, or the named ones in the given order)."""
        chosen = self.state if fields is None else [self.field(f) for f in fields]
        return [n for f in chosen for n in f.names]
