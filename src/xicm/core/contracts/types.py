"""Plain data passed between the stages of X-ICM. Units: metres, radians, world frame."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: (low xyz, high xyz) of an axis-aligned box, metres: the workspace the 100^3 text grid covers.
Box = tuple[tuple[float, float, float], tuple[float, float, float]]


@dataclass(frozen=True)
class KeyAction:
    """One key pose of the end effector and the gripper state to set after reaching it."""

    position: tuple[float, float, float]
    quat_wxyz: tuple[float, float, float, float]
    gripper_open: bool


@dataclass(frozen=True)
class JointAction:
    """A target configuration of the arm's joints (radians) and the gripper state to set after
    reaching it: what joint-space policies (e.g. VLAs trained on joint targets) return."""

    positions: tuple[float, ...]
    gripper_open: bool


@dataclass(frozen=True)
class ControlStep:
    """One control period of per-step control (`Simulator.step`): the action vector in the
    simulator's control mode (Simulator.control_spec().step_mode: its columns and bounds). A policy
    returns one, or several as an action chunk."""

    values: tuple[float, ...]


@dataclass
class CameraFrame:
    """One camera's picture. Extrinsics use the OpenCV convention (x right, y down, z forward)."""

    rgb: np.ndarray  # (H, W, 3) uint8
    depth: np.ndarray | None  # (H, W) float32 metres along the optical axis; 0 where nothing was hit
    segmentation: np.ndarray | None  # (H, W) int32 actor ids, see Observation.segment_names
    # (None when the simulator was asked not to render them, e.g. sapien's depth=false)
    intrinsic: np.ndarray  # (3, 3)
    cam_to_world: np.ndarray  # (4, 4)


@dataclass
class Observation:
    """What the agent may see at one instant."""

    instruction: str
    cameras: dict[str, CameraFrame]
    segment_names: dict[int, str]  # segmentation id -> name of the task object it belongs to
    object_names: list[str]  # the task objects to describe in the prompt, in prompt order
    gripper: KeyAction  # current end-effector pose and gripper state
    joint_positions: np.ndarray
    #: laid out as Simulator.control_spec().state (SAPIEN: joint_positions (7), gripper_width (1, m),
    #: tcp_pose (7: xyz + wxyz, robot base frame), gripper_open (1: the commanded state, 1.0 / 0.0));
    #: empty where a simulator has none
    proprio: dict[str, np.ndarray] = field(default_factory=dict)

    def first_camera(self) -> str | None:
        """The camera whose pictures a pool stores and X-ICM's query shows: the first one rendered,
        in the simulator's own order (simulator.cameras; SAPIEN's starts with front); None if none was."""
        return next(iter(self.cameras), None)


@dataclass(frozen=True)
class TaskInfo:
    """Static facts about a task: its split ('seen', 'level1', 'level2') and instruction."""

    name: str
    split: str
    instruction: str
    object_names: tuple[str, ...]
    #: default budget of per-step policies (control steps), None where the task declares none
    max_control_steps: int | None = None
    #: every phrasing of variation 0, the instruction first (a task attribute `phrasings`; empty: the instruction only)
    phrasings: tuple[str, ...] = ()

    @classmethod
    def of(cls, name: str, task: Any) -> TaskInfo:
        """The facts of a registered task class: its attributes split, instruction and object_names
        (and max_control_steps if it has one)."""
        missing = [a for a in ("split", "instruction", "object_names") if not hasattr(task, a)]
        if missing:
            from xicm.core.contracts.errors import ConfigError

            raise ConfigError(f"task '{name}' has no {', '.join(missing)} (a task class declares split, instruction and object_names)")
        budget = getattr(task, "max_control_steps", None)
        return cls(name, task.split, task.instruction, tuple(task.object_names), None if budget is None else int(budget),
                   tuple(getattr(task, "phrasings", ())))


@dataclass
class StepOutcome:
    """Result of executing one key action in the simulator."""

    ok: bool  # False when the pose could not be reached or the simulator failed
    success: bool  # task success checked after the move
    error_kind: str | None = None  # e.g. "unreachable", "sim_error"
    error_message: str | None = None


@dataclass
class Trajectory:
    """A recorded scripted run: one row per frame (see DESIGN.md, frame rate)."""

    joint_positions: np.ndarray  # (T, n_joints)
    joint_velocities: np.ndarray  # (T, n_joints)
    gripper_open: np.ndarray  # (T,) bool
    ee_poses: np.ndarray  # (T, 7) position xyz + quaternion wxyz
    success: bool


@dataclass
class ControlRecording:
    """A scripted demonstration recorded at the control rate (Simulator.record_scripted).

    Index t runs over the T + 1 states: the reset state, then the state after each of the T
    control steps. The targets at index t are the commands in force at the end of control
    period t - 1 (index 0: the hold target at reset); action t of any control mode leads from
    state t to the targets at t + 1 (`actions` holds them per per-step control mode).
    """

    task: str
    seed: int
    episode: int
    instruction: str
    control_hz: float
    proprio: dict[str, np.ndarray]  # name -> (T + 1, d), the layout of Observation.proprio
    joint_targets: np.ndarray  # (T + 1, n_joints) commanded arm joint targets (SAPIEN: the Panda's 7, rad)
    tcp_targets: np.ndarray  # (T + 1, 7) TCP pose (xyz + wxyz) of the joint targets, robot base frame
    gripper_commands: np.ndarray  # (T + 1,) 1.0 open / 0.0 closed
    rgb: dict[str, np.ndarray] | None  # camera -> (T + 1, H, W, 3) uint8, None when not rendered
    key_action_steps: list[int]  # per key action: the control step (0-based) during which it ended
    key_actions: list[KeyAction]
    success: bool
    error: str | None = None  # why the demonstrator stopped early, if it did
    #: per-step control mode -> (T, width) actions that replay the recording through step()
    actions: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def steps(self) -> int:
        return len(self.joint_targets) - 1


@dataclass
class Demo:
    """A demonstration as it is stored in the pool and shown to the LLM."""

    demo_id: str
    task: str
    instruction: str
    seed: int
    episode: int
    objects: dict[str, tuple[float, float, float]]  # first-frame object centres (metres)
    key_actions: list[KeyAction]
    first_rgb: np.ndarray | None = None
    last_rgb: np.ndarray | None = None
    first_depth: np.ndarray | None = None
    last_depth: np.ndarray | None = None
    trajectory: Trajectory | None = None


@dataclass
class Query:
    """What the agent knows about the episode it must solve when it asks the LLM."""

    task: str
    instruction: str
    objects: dict[str, tuple[float, float, float]]
    front_rgb: np.ndarray | None = None  # the first camera's picture (Observation.first_camera; SAPIEN: front)
    missing: tuple[str, ...] = ()  # object names the detector did not find (the prompt says so)


@dataclass
class Prompt:
    """Chat messages plus the structured pieces they were made from (for LLM-free baselines)."""

    messages: list[dict[str, str]]
    demos: list[Demo]
    query: Query
    workspace: tuple[tuple[float, float, float], tuple[float, float, float]]
    # The query's objects (metres) in the order the prompt lists them, when the prompt writes actions
    # anchored on objects (xicm.core.text.encoding, "anchored actions"); None: absolute 7-integer actions.
    anchors: tuple[tuple[float, float, float], ...] | None = None
    # Each demo's objects (metres) in the order the prompt lists them, beside `demos`, when anchored.
    demo_anchors: tuple[tuple[tuple[float, float, float], ...], ...] | None = None


@dataclass
class EpisodeResult:
    """One evaluated episode; one line of episodes.jsonl."""

    task: str
    seed: int
    episode: int
    success: bool
    steps: int
    error_kind: str | None = None
    error_message: str | None = None
    retrieved: list[str] = field(default_factory=list)
    prompt_hash: str | None = None
    responses: list[str] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)
