"""SapienSimulator: the xicm Simulator interface over a SAPIEN scene built anew for every episode."""

from __future__ import annotations

from typing import Callable, Mapping

import numpy as np
import sapien

from xicm.core.contracts.errors import EpisodeFailure
from xicm.core.contracts.interfaces import Simulator
from xicm.core.assembly.seeding import episode_rng
from xicm.core.contracts.spaces import ControlSpec
from xicm.core.contracts.types import (
    ControlRecording,
    JointAction,
    KeyAction,
    Observation,
    StepOutcome,
    TaskInfo,
    Trajectory,
)

from . import control_modes, spec
from .controller import Controller, MotionLimits, Unreachable
from .grasp import GraspAttacher
from .objects import ObjectSet
from .options import SapienOptions, frames_per_step, sizes_per_camera
from .robot import ARM_JOINTS
from .scene import RLBENCH_WORKSPACE_Z, TABLE_TOP_Z, WORKSPACE, World
from .task_base import Task


class SapienSimulator(Simulator):
    """AGNOSTOS-style tabletop scenes with a Franka Panda, rendered headless through Vulkan.

    Built from its options (options.py SapienOptions: each option's meaning and default, checked
    by the registry before this runs) and the tasks it can load, name -> Task class (or a stand-in
    such as tasks.LazyTask): those registered for simulator "sapien", handed over by
    Registry.create_simulator. `sample_variations` (the Simulator interface's) is set by the run
    from benchmark.variations.
    """

    workspace = WORKSPACE

    def __init__(self, options: SapienOptions, *, tasks: Mapping[str, Callable[[World, ObjectSet], Task]]):
        o = self.options = options
        self._build_world()
        self.frames_per_step = frames_per_step(o.frame_hz, o.control_hz)
        self.control_hz = float(o.control_hz)
        self.control_mode = o.control_mode
        self.grasp_mode = o.grasp
        self.per_frame_success = o.success_check == "per_frame"
        self.gripper_after_success = o.gripper_after_success
        self.workspace_check = o.workspace_check
        self.scenes = o.scenes
        self.max_scene_draws = o.max_scene_draws
        self.scene_draw = 0  # which draw of the episode's scene is set up (scenes: rlbench)
        self.tasks = dict(tasks)
        self.task = None
        self.task_name: str | None = None
        self.seed = self.episode = None

    def _build_world(self) -> None:
        """A new SAPIEN scene (robot, cameras) and the controller over it; every set-up starts one.

        A live PhysX scene keeps solver state from the episodes run in it: an episode then moved
        its objects by ~1e-4 m differently after other episodes, which a 1 cm voxel in an LLM's
        prompt can turn into another reply (measured: 13 of 345 episodes of one row differed in
        steps or outcome between a run with `envs=2` and one with `envs=1`). A new scene adds
        about 30 ms to a rendered reset (median 247 against 218 ms, measured alternating)."""
        o = self.options
        cameras = tuple(str(c) for c in o.cameras)
        self.world = World(
            physics_hz=float(o.physics_hz),
            image_size=sizes_per_camera(o.image_size, cameras),
            cameras=cameras,
            render=o.render,
            depth=o.depth,
            segmentation=o.segmentation,
            robot=o.robot,
        )
        self.robot = self.world.robot
        self.objects = ObjectSet(self.world.scene)
        self.controller = Controller(
            self.world.scene,
            self.robot,
            o.physics_hz,
            o.frame_hz,
            MotionLimits(lin_speed=o.lin_speed, joint_speed=o.joint_speed),
        )
        if o.grasp == "attach":
            self.world.grasp = self.controller.grasp = GraspAttacher(self.world.scene, self.robot)

    # --- catalogue -------------------------------------------------------------------------
    def task_names(self) -> list[str]:
        return sorted(self.tasks)

    def task_info(self, task: str) -> TaskInfo:
        return TaskInfo.of(task, self._task_class(task))

    def _task_class(self, task: str) -> Callable[[World, ObjectSet], Task]:
        try:
            return self.tasks[task]
        except KeyError:
            raise KeyError(f"unknown task '{task}'; available: {', '.join(sorted(self.tasks))}") from None

    # --- episodes --------------------------------------------------------------------------
    def reset(self, task: str, seed: int, episode: int) -> Observation:
        self.reset_state(task, seed, episode)
        return self.observe()

    def reset_state(self, task: str, seed: int, episode: int) -> None:
        """reset() without rendering (physics-only work such as collecting trajectories).

        scenes: rlbench: the scene is drawn from RLBench's ranges again and again (each draw from
        its own seeded stream) until the task's scripted solution solves it, as RLBench's stored
        evaluation episodes are scenes its demonstrator solved; then that draw is set up afresh."""
        draw = self._solvable_draw(task, seed, episode) if self.scenes == "rlbench" else 0
        self._set_up(task, seed, episode, draw)

    def _solvable_draw(self, task: str, seed: int, episode: int) -> int:
        for draw in range(self.max_scene_draws):
            self._set_up(task, seed, episode, draw)
            if self.demonstrate().success:
                return draw
        raise EpisodeFailure(
            "unsolvable_scene",
            f"{task} seed {seed} episode {episode}: the scripted solution solved none of {self.max_scene_draws} "
            "scenes drawn from RLBench's ranges (simulator.max_scene_draws)"
        )

    def _set_up(self, task: str, seed: int, episode: int, draw: int) -> None:
        cls = self._task_class(task)
        self._build_world()
        self.robot.reset()
        self.task = cls(self.world, self.objects)
        self.task.ranges = self.scenes  # before load(): a task may build RLBench's objects under it
        self.task.load()
        rng = episode_rng(seed, task, episode, "scene" if draw == 0 else f"scene-draw-{draw}")
        self.task.initialise(rng, self.sample_variations)
        self.scene_draw = draw
        if self.world.grasp is not None:
            self.world.grasp.reset(self.task.graspable_ids())
        self.task_name, self.seed, self.episode = task, int(seed), int(episode)
        self.controller.on_frame = self.task.on_frame  # also drops a video frame callback
        self.task.latching = self.per_frame_success
        self.controller.success_check = self.task.evaluate if self.per_frame_success else None
        self.controller.recorder = None
        # let objects settle under gravity before the episode starts
        for _ in range(self.controller.substeps * 2):
            self.world.scene.step()
        self.robot.reset()
        self.controller.reset()

    def _require_task(self) -> None:
        if self.task is None:
            raise RuntimeError("call reset(task, seed, episode) first")

    def image_sizes(self) -> dict[str, tuple[int, int]]:
        """(height, width) of each camera."""
        return dict(self.world.cameras.sizes) if self.world.cameras is not None else {}

    def object_names(self) -> list[str]:
        self._require_task()
        return list(getattr(self.task, "episode_object_names", self.task.object_names))

    def gripper_action(self) -> KeyAction:
        pose = self.robot.tcp_pose()
        q = np.asarray(pose.q, dtype=float)
        if q[0] < 0:
            q = -q
        return KeyAction(tuple(float(v) for v in pose.p), tuple(float(v) for v in q), self.robot.gripper_open)

    def observe(self, cameras=None) -> Observation:
        self._require_task()
        frames = self.world.render(None if cameras is None else [str(c) for c in cameras])
        return Observation(
            instruction=self.task.episode_instruction,
            cameras=frames,
            segment_names=dict(self.objects.segment_names),
            object_names=self.object_names(),
            gripper=self.gripper_action(),
            joint_positions=self.robot.qpos.copy(),
            proprio=self.proprio(),
        )

    def instruction(self) -> str:
        self._require_task()
        return self.task.episode_instruction

    def variation(self) -> int:
        self._require_task()
        return int(self.task.variation)

    def proprio(self) -> dict[str, np.ndarray]:
        """joint_positions (7), gripper_width (1, m), tcp_pose (7, base frame), gripper_open (1): spec.STATE."""
        self._require_task()
        return {
            "joint_positions": self.robot.arm_qpos(),
            "gripper_width": np.array([self.robot.finger_width()]),
            "tcp_pose": self.robot.in_base(self.robot.tcp_pose()),
            "gripper_open": np.array([1.0 if self.robot.gripper_open else 0.0]),
        }

    def object_positions(self) -> dict[str, tuple[float, float, float]]:
        """True world centre of every named object (mean of its links' bounding-box centres)."""
        self._require_task()
        out: dict[str, list[np.ndarray]] = {}
        entities = {e.per_scene_id: e for e in self.world.scene.entities}
        for sid, name in self.objects.segment_names.items():
            ent = entities.get(sid)
            if ent is None:
                continue
            body = ent.find_component_by_type(sapien.physx.PhysxRigidBaseComponent)
            if body is None or not body.collision_shapes:
                continue
            lo, hi = body.compute_global_aabb_tight()
            out.setdefault(name, []).append((np.asarray(lo) + np.asarray(hi)) / 2)
        return {n: tuple(float(v) for v in np.mean(c, axis=0)) for n, c in out.items()}

    # --- acting ----------------------------------------------------------------------------
    def refused_target(self, action: KeyAction) -> tuple[str, str] | None:
        """(error kind, one sentence) when the pose cannot be a target, or None."""
        p = np.asarray(action.position, dtype=float)
        q = np.asarray(action.quat_wxyz, dtype=float)
        if p.shape != (3,) or q.shape != (4,) or not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
            return "unreachable", "the key action's position or quaternion is not a finite 3-vector / 4-vector"
        if np.linalg.norm(q) < 1e-6:
            return "unreachable", "the key action's quaternion has zero length"
        lo, hi = (np.asarray(v) for v in self.workspace)
        if self.workspace_check == "rlbench":
            z_lo, z_hi = RLBENCH_WORKSPACE_Z
            if not z_lo - 1e-6 <= p[2] <= z_hi + 1e-6:
                return "out_of_workspace", (
                    f"position {np.round(p, 3).tolist()} lies outside RLBench's workspace in z "
                    f"({z_lo:g} to {z_hi:g} m: the table top to 1 m above it)"
                )
            lo, hi = lo.copy(), hi.copy()
            lo[2], hi[2] = z_lo, z_hi  # x/y: the grid box's (RLBench's x/y extents are unknown here)
        if np.any(p < lo - 1e-6) or np.any(p > hi + 1e-6):
            return "unreachable", f"position {np.round(p, 3).tolist()} lies outside the workspace box {lo.tolist()} to {hi.tolist()}"
        if p[2] < TABLE_TOP_Z:
            return "unreachable", f"position {np.round(p, 3).tolist()} is below the table top (z = {TABLE_TOP_Z} m)"
        return None

    def execute(self, action: KeyAction | JointAction) -> StepOutcome:
        try:
            self._require_task()
            if isinstance(action, JointAction):
                return self._execute_joints(action)
            if self.controller.halted:  # succeeded in an earlier frame: nothing more to do
                return StepOutcome(ok=True, success=True)
            refused = self.refused_target(action)
            if refused is not None:
                return StepOutcome(False, self.is_success(), error_kind=refused[0], error_message=refused[1])
            q = np.asarray(action.quat_wxyz, dtype=float)
            target = sapien.Pose(np.asarray(action.position, dtype=float), q / np.linalg.norm(q))
            try:
                self.controller.move_to(target)
            except Unreachable as exc:
                return StepOutcome(False, self.is_success(), error_kind="unreachable", error_message=str(exc))
            self._gripper(bool(action.gripper_open))
            return StepOutcome(ok=True, success=self.is_success())
        except Exception as exc:  # noqa: BLE001 - a simulator failure must not crash the run
            return StepOutcome(False, False, error_kind="sim_error", error_message=f"{type(exc).__name__}: {exc}")

    def _execute_joints(self, action: JointAction) -> StepOutcome:
        """A straight joint-space line to the target, then the gripper."""
        q = np.asarray(action.positions, dtype=float)
        lo, hi = self.robot.qlimits[:, 0], self.robot.qlimits[:, 1]
        if q.shape != (len(lo),) or not np.all(np.isfinite(q)):
            why = f"a joint action needs {len(lo)} finite arm joint positions, got {np.asarray(action.positions).shape}"
            return StepOutcome(False, self.is_success(), error_kind="unreachable", error_message=why)
        if np.any(q < lo - 1e-6) or np.any(q > hi + 1e-6):
            bad = [int(j) + 1 for j in np.nonzero((q < lo - 1e-6) | (q > hi + 1e-6))[0]]
            why = f"joint target outside the Panda's limits at joint(s) {bad}"
            return StepOutcome(False, self.is_success(), error_kind="unreachable", error_message=why)
        self.controller.move_joints(q)
        self._gripper(bool(action.gripper_open))
        return StepOutcome(ok=True, success=self.is_success())

    def _gripper(self, open_: bool) -> None:
        """The key action's gripper command, after its move. A move that met success part-way
        (success_check: per_frame) skips it; with gripper_after_success, as X-ICM's RLBench, the
        gripper still acts, unwatched, and success is then read once (is_success)."""
        if not self.controller.halted:
            self.controller.set_gripper(open_)
            return
        if not self.gripper_after_success:
            return
        watch, self.controller.success_check = self.controller.success_check, None
        self.controller.halted = False
        try:
            self.controller.set_gripper(open_)
        finally:
            self.controller.success_check = watch

    # --- per-step control -------------------------------------------------------------------
    def control_spec(self) -> ControlSpec:
        return spec.control_spec(self.robot.qlimits, self.robot.base_pose.p, self.workspace, self.control_mode, self.control_hz)

    def step(self, action) -> StepOutcome:
        """One control period (frame_hz / control_hz frames) towards `action` in control_mode."""
        try:
            self._require_task()
            values, problem = control_modes.parse(self.control_mode, action)
            if problem is not None:
                return StepOutcome(False, self.is_success(), error_kind="bad_action", error_message=problem)
            if self.controller.halted:  # succeeded in an earlier frame (success_check: per_frame)
                return StepOutcome(ok=True, success=True)
            target, problem = self._arm_target(values)
            if problem is not None:
                return StepOutcome(False, self.is_success(), error_kind="unreachable", error_message=problem)
            self.controller.drive(target, control_modes.gripper_open(values), self.frames_per_step)
            return StepOutcome(ok=True, success=self.is_success())
        except Exception as exc:  # noqa: BLE001 - a simulator failure must not crash the run
            return StepOutcome(False, False, error_kind="sim_error", error_message=f"{type(exc).__name__}: {exc}")

    def _arm_target(self, values: np.ndarray) -> tuple[np.ndarray | None, str | None]:
        """The arm joint target of an action, or None and why it cannot be reached."""
        mode = self.control_mode
        if mode in ("joint_pos", "joint_delta"):
            q = control_modes.joint_target(mode, values, self.robot.arm_qpos())
        else:
            try:
                pose = control_modes.target_pose(mode, values, self.robot.in_base(self.robot.tcp_pose()))
            except ValueError as exc:
                return None, str(exc)
            world = self.robot.base_pose * sapien.Pose(pose[:3], pose[3:])
            q = self._ik_near(world, self.controller._hold_q)
            if q is None:
                xyz = np.round(pose[:3], 3).tolist()
                return None, f"no joint configuration within the Panda's limits puts the gripper at {xyz} (base frame)"
        lo, hi = self.robot.qlimits[:, 0], self.robot.qlimits[:, 1]
        outside = (q < lo - 1e-6) | (q > hi + 1e-6)
        if np.any(outside):
            bad = [int(j) + 1 for j in np.nonzero(outside)[0]]
            return None, f"the {mode} action's joint target lies outside the Panda's limits at joint(s) {bad}"
        return q, None

    def _ik_near(self, world: sapien.Pose, hold: np.ndarray) -> np.ndarray | None:
        """IK seeded from the commanded joints (the measured ones lag them while moving). The
        solver knows no joint limits: a solution past one is solved again with that joint held
        at the limit (the arm has a joint to spare), else from a seed pulled inside the limits."""
        robot = self.robot
        lo, hi = robot.qlimits[:, 0], robot.qlimits[:, 1]
        mask = np.ones(ARM_JOINTS, dtype=np.int32)
        seed = hold.copy()
        for _ in range(3):
            q, ok = robot.ik_masked(world, seed, mask)
            if not ok:
                break
            past = ((q < lo - 1e-3) | (q > hi + 1e-3)) & (mask == 1)
            if not past.any():
                return np.clip(q, lo, hi)
            mask[past] = 0  # hold these joints at their limits and solve with the others
            seed = np.where(past, np.clip(q, lo, hi), seed)
        return robot.ik(world, np.clip(hold, lo + 0.2, hi - 0.2))

    def record_scripted(self, cameras=None) -> ControlRecording:
        """Run the scripted solution from the reset state, recording at the control rate: the
        state and commanded targets every frames_per_step frames, RGB of `cameras` if given."""
        self._require_task()
        cams = None if cameras is None else [str(c) for c in cameras]
        k = self.frames_per_step
        rows: dict[str, list] = {"proprio": [], "joint": [], "grip": [], "rgb": []}

        def capture() -> None:
            rows["proprio"].append(self.proprio())
            rows["joint"].append(self.robot.arm_target.copy())
            rows["grip"].append(1.0 if self.robot.gripper_open else 0.0)
            if cams is not None:
                frames = self.world.render(cams)
                rows["rgb"].append({c: frames[c].rgb for c in cams})

        start = self.controller.frames

        def on_frame() -> None:
            if (self.controller.frames - start) % k == 0:
                capture()

        capture()
        self.set_frame_callback(on_frame)
        key_actions, key_steps, error = [], [], None
        try:
            for action in self.task.demonstration():
                outcome = self.execute(action)
                if not outcome.ok:
                    error = outcome.error_message
                    break
                key_actions.append(action)
                key_steps.append(max(0, -(-(self.controller.frames - start) // k) - 1))
            while (self.controller.frames - start) % k:  # complete the last control period
                self.controller.step_frame()
        finally:
            self.set_frame_callback(None)
        joints = np.array(rows["joint"])
        tcp = np.array([self.robot.in_base(self.robot.tcp_pose_at(q)) for q in joints])
        recording = ControlRecording(
            task=self.task_name,
            seed=self.seed,
            episode=self.episode,
            instruction=self.task.episode_instruction,
            control_hz=self.control_hz,
            proprio={n: np.array([p[n] for p in rows["proprio"]]) for n in rows["proprio"][0]},
            joint_targets=joints,
            tcp_targets=tcp,
            gripper_commands=np.array(rows["grip"]),
            rgb=None if cams is None else {c: np.array([r[c] for r in rows["rgb"]]) for c in cams},
            key_action_steps=key_steps,
            key_actions=key_actions,
            success=error is None and self.is_success(),
            error=error,
        )
        recording.actions = {mode: control_modes.actions(recording, mode) for mode in control_modes.ACTION_DIMS}
        return recording

    def set_frame_callback(self, callback) -> bool:
        """Call `callback()` after every frame (after the task's own frame hook); for
        rollout videos. None, or the next reset, removes it."""
        self._require_task()
        task_hook = self.task.on_frame
        if callback is None:
            self.controller.on_frame = task_hook
        else:

            def both() -> None:
                task_hook()
                callback()

            self.controller.on_frame = both
        return True

    def is_success(self) -> bool:
        self._require_task()
        self.task.on_step_end()  # read at the end of every key action and step
        return self.controller.halted or bool(self.task.evaluate())

    def scripted_solution(self):
        self._require_task()
        return self.task.demonstration()

    def demonstrate(self) -> Trajectory:
        self._require_task()
        frames = [self.controller.snapshot()]
        self.controller.recorder = frames
        error = None
        try:
            for action in self.task.demonstration():
                outcome = self.execute(action)
                if not outcome.ok:
                    error = outcome.error_message
                    break
        finally:
            self.controller.recorder = None
        self.last_demo_error = error
        return Trajectory(
            joint_positions=np.array([f.qpos for f in frames]),
            joint_velocities=np.array([f.qvel for f in frames]),
            gripper_open=np.array([f.gripper_open for f in frames], dtype=bool),
            ee_poses=np.array([f.tcp for f in frames]),
            success=error is None and self.is_success(),
        )

    def close(self) -> None:
        if self.task is not None:
            self.objects.clear()
        self.task = None
        self.world = None  # type: ignore[assignment]


