"""KinematicSimulator: the xicm Simulator contract over the kinematic world (world.py), a
second simulator beside SAPIEN that proves every track goes through src/xicm/core/contracts/interfaces.py.

Time is counted in control periods: a period moves the TCP at most lin_speed / control_hz
metres towards its target and then sets the gripper. A key action is played as the periods that
reach its pose, plus one for its gripper command when that changes the gripper.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from xicm.core.contracts.interfaces import Simulator
from xicm.core.assembly.seeding import episode_rng
from xicm.core.contracts.spaces import GRIPPER_CLOSED, GRIPPER_OPEN, GRIPPER_THRESHOLD, ControlSpec, key_pose_mode, layout
from xicm.core.contracts.types import ControlRecording, KeyAction, Observation, StepOutcome, TaskInfo, Trajectory

from .render import CAMERAS, SEGMENTS, render
from .world import WORKSPACE, World

STEP_MODES = {  # per-step mode -> (columns, doc); the gripper is last
    "ee_delta": (("dx", "dy", "dz", "gripper"), "a TCP displacement (m, world frame), then the gripper"),
    "ee_pos": (("x", "y", "z", "gripper"), "a TCP position (m, world frame), then the gripper"),
}
STATE = (  # the proprio layout: a gantry's three prismatic joints are the TCP's x, y, z
    ("joint_positions", ("x", "y", "z"), "gantry joints = TCP position (m)"),
    ("gripper_width", ("gripper_width",), "distance between the fingers (m)"),
    ("gripper_open", ("gripper_open",), "1 open, 0 closed (the last command)"),
)


class KinematicSimulator(Simulator):
    workspace = WORKSPACE

    def __init__(self, image_size=64, cameras=CAMERAS, control_mode: str = "ee_delta", control_hz: float = 10.0,
                 lin_speed: float = 0.5, render: bool = True, *, tasks: dict):
        h, w = (image_size, image_size) if isinstance(image_size, int) else tuple(image_size)
        self.sizes = {str(c): (int(h), int(w)) for c in cameras} if render else {}
        self.control_mode, self.control_hz = str(control_mode), float(control_hz)
        self.max_travel = float(lin_speed) / self.control_hz
        self.tasks = dict(tasks)
        self.world: World | None = None
        self.task = self.task_name = None
        self.seed = self.episode = None
        self.on_period: Callable[[], None] | None = None

    # --- catalogue and episodes -------------------------------------------------------------
    def task_names(self) -> list[str]:
        return sorted(self.tasks)

    def task_info(self, task: str) -> TaskInfo:
        return TaskInfo.of(task, self.tasks[task])

    def reset_state(self, task: str, seed: int, episode: int) -> None:
        if task not in self.tasks:
            raise KeyError(f"unknown task '{task}'; available: {', '.join(self.task_names())}")
        from .tasks import sample_world

        self.world = sample_world(episode_rng(seed, task, episode, "scene"))
        self.task, self.task_name, self.seed, self.episode = self.tasks[task], task, int(seed), int(episode)
        self.on_period = None

    def reset(self, task: str, seed: int, episode: int) -> Observation:
        self.reset_state(task, seed, episode)
        return self.observe()

    def _world(self) -> World:
        if self.world is None:
            raise RuntimeError("call reset(task, seed, episode) first")
        return self.world

    # --- observing ---------------------------------------------------------------------------
    def image_sizes(self) -> dict[str, tuple[int, int]]:
        return dict(self.sizes)

    def observe(self, cameras=None) -> Observation:
        world = self._world()
        names = list(self.sizes) if cameras is None else [str(c) for c in cameras]
        unknown = [c for c in names if c not in self.sizes]
        if unknown:
            raise ValueError(f"camera {', '.join(unknown)} is not rendered; cameras: {', '.join(self.sizes) or 'none'}")
        return Observation(
            instruction=self.instruction(),
            cameras={c: render(world, c, self.sizes[c]) for c in names},
            segment_names=dict(SEGMENTS),
            object_names=list(self.task.object_names),
            gripper=KeyAction(tuple(float(v) for v in world.tcp), (1.0, 0.0, 0.0, 0.0), world.gripper_open),
            joint_positions=world.tcp.copy(),
            proprio=self.proprio(),
        )

    def instruction(self) -> str:
        self._world()
        return self.task.instruction

    def proprio(self) -> dict[str, np.ndarray]:
        world = self._world()
        return {
            "joint_positions": world.tcp.copy(),
            "gripper_width": np.array([world.gripper_width()]),
            "gripper_open": np.array([1.0 if world.gripper_open else 0.0]),
        }

    def control_spec(self) -> ControlSpec:
        lo, hi = (np.asarray(v, dtype=float) for v in WORKSPACE)
        d = self.max_travel
        bounds = {"ee_delta": ([-d] * 3, [d] * 3), "ee_pos": (lo, hi)}
        modes = [layout(n, cols, [*bounds[n][0], GRIPPER_CLOSED], [*bounds[n][1], GRIPPER_OPEN], doc, per_step=True)
                 for n, (cols, doc) in STEP_MODES.items()]
        state_bounds = {"joint_positions": (lo, hi), "gripper_width": ([0.0], [0.1]), "gripper_open": ([0.0], [1.0])}
        state = tuple(layout(n, cols, *state_bounds[n], doc) for n, cols, doc in STATE)
        return ControlSpec(modes=(*modes, key_pose_mode(WORKSPACE)), state=state, control_mode=self.control_mode,
                           control_hz=self.control_hz)

    # --- acting ------------------------------------------------------------------------------
    def is_success(self) -> bool:
        return bool(self.task.success(self._world()))

    def _outside(self, p: np.ndarray) -> str | None:
        lo, hi = (np.asarray(v) for v in WORKSPACE)
        if np.any(p < lo - 1e-9) or np.any(p > hi + 1e-9):
            return f"position {np.round(p, 3).tolist()} lies outside the workspace box {lo.tolist()} to {hi.tolist()}"
        return None

    def _period(self, target: np.ndarray, open_: bool) -> None:
        """One control period: towards `target` (at most max_travel), then the gripper."""
        world = self._world()
        step = target - world.tcp
        dist = float(np.linalg.norm(step))
        world.move(target if dist <= self.max_travel else world.tcp + step * (self.max_travel / dist))
        world.set_gripper(open_)
        if self.on_period is not None:
            self.on_period()

    def step(self, action) -> StepOutcome:
        world = self._world()
        width = len(STEP_MODES[self.control_mode][0])
        try:
            values = np.asarray(action, dtype=float).reshape(-1)
            got = f"shape {values.shape}" if values.shape != (width,) else "NaN or infinite values"
        except (TypeError, ValueError):
            values, got = None, f"a {type(action).__name__} that is not numbers"
        if values is None or values.shape != (width,) or not np.all(np.isfinite(values)):
            why = f"a {self.control_mode} action is {width} finite numbers, got {got}"
            return StepOutcome(False, self.is_success(), error_kind="bad_action", error_message=why)
        target = world.tcp + values[:3] if self.control_mode == "ee_delta" else values[:3]
        problem = self._outside(target)
        if problem is not None:
            return StepOutcome(False, self.is_success(), error_kind="unreachable", error_message=problem)
        self._period(target, values[3] >= GRIPPER_THRESHOLD)
        return StepOutcome(True, self.is_success())

    def execute(self, action) -> StepOutcome:
        world = self._world()
        if not isinstance(action, KeyAction):
            why = f"this simulator plays key poses only, not {type(action).__name__}"
            return StepOutcome(False, self.is_success(), error_kind="unreachable", error_message=why)
        p, q = np.asarray(action.position, dtype=float), np.asarray(action.quat_wxyz, dtype=float)
        if p.shape != (3,) or q.shape != (4,) or not np.all(np.isfinite(p)) or not np.all(np.isfinite(q)) or not q.any():
            why = "the key action's position or quaternion is not a finite 3-vector / non-zero 4-vector"
            return StepOutcome(False, self.is_success(), error_kind="unreachable", error_message=why)
        problem = self._outside(p)
        if problem is not None:
            return StepOutcome(False, self.is_success(), error_kind="unreachable", error_message=problem)
        while np.linalg.norm(p - world.tcp) > 1e-12:
            self._period(p, world.gripper_open)
        if bool(action.gripper_open) != world.gripper_open:
            self._period(p, bool(action.gripper_open))
        return StepOutcome(True, self.is_success())

    def set_frame_callback(self, callback) -> bool:
        self.on_period = callback
        return True

    def scripted_solution(self):
        return self.task.solution(self._world())

    # --- recording ---------------------------------------------------------------------------
    def _play_solution(self, capture: Callable[[], None]) -> tuple[list[KeyAction], list[int], str | None]:
        """The scripted solution with `capture()` after every period: (key actions, the period
        each ended in, why it stopped early)."""
        periods = [0]

        def counted() -> None:
            periods[0] += 1
            capture()

        self.on_period = counted
        done, ends, error = [], [], None
        try:
            for action in self.scripted_solution():
                outcome = self.execute(action)
                if not outcome.ok:
                    error = outcome.error_message
                    break
                done.append(action)
                ends.append(max(0, periods[0] - 1))
        finally:
            self.on_period = None
        return done, ends, error

    def record_scripted(self, cameras=None) -> ControlRecording:
        world = self._world()
        rows: list[tuple[dict, bool, dict | None]] = []

        def capture() -> None:
            frames = None if cameras is None else {c: render(world, c, self.sizes[c]).rgb for c in cameras}
            rows.append((self.proprio(), world.gripper_open, frames))

        capture()
        key_actions, ends, error = self._play_solution(capture)
        tcp = np.array([r[0]["joint_positions"] for r in rows])
        grip = np.array([1.0 if r[1] else 0.0 for r in rows])
        recording = ControlRecording(
            task=self.task_name, seed=self.seed, episode=self.episode, instruction=self.instruction(),
            control_hz=self.control_hz,
            proprio={f[0]: np.array([r[0][f[0]] for r in rows]) for f in STATE},
            joint_targets=tcp, tcp_targets=np.hstack([tcp, np.tile([1.0, 0.0, 0.0, 0.0], (len(tcp), 1))]),
            gripper_commands=grip,
            rgb=None if cameras is None else {c: np.array([r[2][c] for r in rows]) for c in cameras},
            key_action_steps=ends, key_actions=key_actions, success=error is None and self.is_success(), error=error,
        )
        # every period reaches its target (moves are at most max_travel): the targets are the next states
        recording.actions = {
            "ee_delta": np.hstack([np.diff(tcp, axis=0), grip[1:, None]]),
            "ee_pos": np.hstack([tcp[1:], grip[1:, None]]),
        }
        return recording

    def demonstrate(self) -> Trajectory:
        world = self._world()
        rows = [(world.tcp.copy(), world.gripper_open)]
        _, _, error = self._play_solution(lambda: rows.append((world.tcp.copy(), world.gripper_open)))
        tcp = np.array([r[0] for r in rows])
        return Trajectory(
            joint_positions=tcp, joint_velocities=np.vstack([np.zeros((1, 3)), np.diff(tcp, axis=0) * self.control_hz]),
            gripper_open=np.array([r[1] for r in rows], dtype=bool),
            ee_poses=np.hstack([tcp, np.tile([1.0, 0.0, 0.0, 0.0], (len(tcp), 1))]),
            success=error is None and self.is_success(),
        )

    def close(self) -> None:
        self.world = None
