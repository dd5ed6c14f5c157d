"""Key-pose control of the TCP: IK along a straight Cartesian line, PD joint drives, gripper, settle.

One `move_to` call plans a path from the current TCP pose to the target (IK per 1 cm / 4 degree
waypoint, seeded from the previous waypoint so the joints stay continuous), falls back to a
joint-space line when the Cartesian line leaves the arm's reach, then follows the path with a
trapezoidal speed profile. Drive targets are interpolated at the physics rate; the state is
recorded (when a recorder is attached) once per frame. The arm always ends at rest.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
import sapien

from .robot import ARM_JOINTS, Panda


class Unreachable(Exception):
    """The target pose has no IK solution within the joint limits (or lies outside the workspace)."""


@dataclass
class MotionLimits:
    lin_speed: float = 0.35  # m/s of the TCP
    ang_speed: float = 1.4  # rad/s of the TCP
    joint_speed: float = 1.3  # rad/s per joint
    ramp: float = 0.1  # s to accelerate / decelerate
    waypoint_step: float = 0.01  # m between Cartesian IK waypoints
    waypoint_angle: float = math.radians(4.0)
    max_joint_jump: float = 0.35  # rad between neighbouring waypoints before the line counts as broken
    rest_speed: float = 0.05  # rad/s: the arm counts as at rest below this on every joint
    settle_frames: int = 40  # at most this many frames to come to rest
    gripper_frames: int = 12  # at most this many frames to open/close
    drop_frames: int = 10  # frames after opening on an attached object (grasp: attach)


@dataclass
class Frame:
    """State of one frame."""

    qpos: np.ndarray
    qvel: np.ndarray
    gripper_open: bool
    tcp: np.ndarray  # xyz + wxyz


def slerp(q0: np.ndarray, q1: np.ndarray, t: float) -> np.ndarray:
    q0 = q0 / np.linalg.norm(q0)
    q1 = q1 / np.linalg.norm(q1)
    dot = float(np.dot(q0, q1))
    if dot < 0:
        q1, dot = -q1, -dot
    if dot > 0.9995:
        q = q0 + t * (q1 - q0)
        return q / np.linalg.norm(q)
    theta = math.acos(min(1.0, dot))
    s = math.sin(theta)
    return (math.sin((1 - t) * theta) * q0 + math.sin(t * theta) * q1) / s


def quat_angle(q0: np.ndarray, q1: np.ndarray) -> float:
    dot = abs(float(np.dot(q0 / np.linalg.norm(q0), q1 / np.linalg.norm(q1))))
    return 2.0 * math.acos(min(1.0, dot))


class Controller:
    """Moves the Panda between key poses while stepping the physics."""

    def __init__(
        self,
        scene: sapien.Scene,
        robot: Panda,
        physics_hz: float,
        frame_hz: float,
        limits: MotionLimits | None = None,
    ):
        self.scene = scene
        self.robot = robot
        self.physics_hz = float(physics_hz)
        self.frame_hz = float(frame_hz)
        self.substeps = max(1, int(round(physics_hz / frame_hz)))
        self.dt = 1.0 / self.physics_hz
        self.limits = limits or MotionLimits()
        #: called once per frame (task event tracking, e.g. which button went down)
        self.on_frame: Callable[[], None] | None = None
        #: the GraspAttacher of `simulator.grasp: attach`, updated first in every frame
        self.grasp = None
        #: `simulator.success_check: per_frame`: the task's success, asked after every frame;
        #: once it holds the controller halts (RLBench ends the move the moment the task succeeds)
        self.success_check: Callable[[], bool] | None = None
        self.halted = False
        #: when a list, one Frame is appended per frame
        self.recorder: list[Frame] | None = None
        self.frames = 0  # frames stepped since the last reset
        self._hold_q = robot.arm_qpos()
        #: joint velocity at the end of the last frame, as the finite difference over
        #: its last physics step: unlike the solver's velocities it reads 0 for an arm held
        #: still against an obstacle (contact jitter), which is what the key-frame rule needs
        self.frame_qvel = np.zeros(ARM_JOINTS)

    def reset(self) -> None:
        self.frames = 0
        self.halted = False
        self._hold_q = self.robot.arm_qpos()
        self.frame_qvel = np.zeros(ARM_JOINTS)

    # --- recording -------------------------------------------------------------------------
    def snapshot(self) -> Frame:
        pose = self.robot.tcp_pose()
        quat = np.asarray(pose.q, dtype=np.float64)
        if quat[0] < 0:
            quat = -quat
        return Frame(
            qpos=self.robot.arm_qpos(),
            qvel=self.frame_qvel.copy(),
            gripper_open=self.robot.gripper_open,
            tcp=np.concatenate([pose.p, quat]).astype(np.float64),
        )

    def _physics_step(self, last: bool) -> None:
        if last:
            before = self.robot.arm_qpos()
            self.scene.step()
            self.frame_qvel = (self.robot.arm_qpos() - before) / self.dt
        else:
            self.scene.step()

    def _end_frame(self) -> None:
        self.frames += 1
        if self.grasp is not None:
            self.grasp.update()
        if self.on_frame is not None:
            self.on_frame()
        if self.recorder is not None:
            self.recorder.append(self.snapshot())
        if self.success_check is not None and not self.halted and self.success_check():
            self.halted = True

    # --- planning --------------------------------------------------------------------------
    def plan(self, target: sapien.Pose) -> np.ndarray:
        """Joint waypoints (N, 7) from the current state to `target`; raises Unreachable."""
        q0 = self._hold_q.copy()
        start = self.robot.tcp_pose_at(q0)
        path = self._cartesian_path(start, target, q0)
        if path is not None:
            return path
        q1 = self._solve(target, q0)
        if q1 is None:
            raise Unreachable("no joint configuration within the Panda's joint limits puts the gripper at this pose")
        n = max(1, int(math.ceil(np.max(np.abs(q1 - q0)) / 0.02)))
        return np.linspace(q0, q1, n + 1)

    def _cartesian_path(self, start: sapien.Pose, target: sapien.Pose, q0: np.ndarray) -> np.ndarray | None:
        lim = self.limits
        p0, p1 = np.asarray(start.p, float), np.asarray(target.p, float)
        r0, r1 = np.asarray(start.q, float), np.asarray(target.q, float)
        n = max(
            1,
            int(math.ceil(np.linalg.norm(p1 - p0) / lim.waypoint_step)),
            int(math.ceil(quat_angle(r0, r1) / lim.waypoint_angle)),
        )
        qs = [q0]
        for i in range(1, n + 1):
            t = i / n
            pose = sapien.Pose(p0 + t * (p1 - p0), slerp(r0, r1, t))
            q = self.robot.ik(pose, qs[-1], iterations=100 if i < n else 300)
            if q is None or np.max(np.abs(q - qs[-1])) > lim.max_joint_jump:
                return None
            qs.append(q)
        return np.array(qs)

    def _solve(self, target: sapien.Pose, q0: np.ndarray) -> np.ndarray | None:
        """The IK solution (over many fixed seeds) closest to q0 and away from the joint limits."""
        lo, hi = self.robot.qlimits[:, 0], self.robot.qlimits[:, 1]
        best, best_cost = None, math.inf
        for seed in [q0, *self._seeds]:
            q = self.robot.ik(target, np.clip(seed, lo, hi), iterations=300)
            if q is None:
                continue
            margin = np.minimum(q - lo, hi - q)
            cost = float(np.linalg.norm(q - q0) + 3.0 * np.sum(np.maximum(0.0, 0.25 - margin)))
            if cost < best_cost:
                best, best_cost = q, cost
        return best

    @property
    def _seeds(self) -> list[np.ndarray]:
        if not hasattr(self, "_seed_cache"):
            lo, hi = self.robot.qlimits[:, 0], self.robot.qlimits[:, 1]
            rng = np.random.default_rng(0)  # fixed: the same pose always gets the same answer
            seeds = [self.robot.home_qpos.copy()]
            for q2, q4, q6 in ((0.2, -2.0, 2.6), (0.5, -1.5, 2.8), (0.0, -2.5, 2.0), (0.8, -1.0, 2.4)):
                for q7 in (np.pi / 4, -np.pi / 4, 3 * np.pi / 4):
                    seeds.append(np.array([0.0, q2, 0.0, q4, 0.0, q6, q7]))
            seeds += [lo + (hi - lo) * rng.uniform(0.1, 0.9, ARM_JOINTS) for _ in range(24)]
            self._seed_cache = seeds
        return self._seed_cache

    # --- execution -------------------------------------------------------------------------
    def follow(self, path: np.ndarray, tcp_path_len: float, tcp_path_angle: float) -> None:
        """Follow joint waypoints with a trapezoidal speed profile, then come to rest."""
        lim = self.limits
        seg = np.abs(np.diff(path, axis=0))  # (N-1, 7)
        n_seg = len(seg)
        # cruise duration of each segment: the slowest of joint, linear and angular limits
        seg_t = np.maximum(seg.max(axis=1) / lim.joint_speed, 1e-6)
        if n_seg > 0:
            seg_t = np.maximum(seg_t, tcp_path_len / n_seg / lim.lin_speed)
            seg_t = np.maximum(seg_t, tcp_path_angle / n_seg / lim.ang_speed)
        cum = np.concatenate([[0.0], np.cumsum(seg_t)])
        tc = float(cum[-1])
        ta = lim.ramp
        if tc >= ta:
            total, peak = tc + ta, 1.0
        else:
            peak = math.sqrt(tc / ta) if tc > 0 else 0.0
            total = 2 * math.sqrt(tc * ta) if tc > 0 else 0.0

        def progress(t: float) -> tuple[float, float]:
            """Cruise-time travelled and its rate at time t."""
            if total <= 0:
                return tc, 0.0
            t = min(max(t, 0.0), total)
            tr = ta * peak  # ramp time for this profile
            acc = peak / tr if tr > 0 else 0.0
            if t < tr:
                return 0.5 * acc * t * t, acc * t
            if t > total - tr:
                r = total - t
                return tc - 0.5 * acc * r * r, acc * r
            return 0.5 * acc * tr * tr + peak * (t - tr), peak

        frame_time = 1.0 / self.frame_hz
        n_frames = max(1, int(math.ceil(total / frame_time - 1e-9)))
        t = 0.0
        for _ in range(n_frames):
            for sub in range(self.substeps):
                t += self.dt
                u, rate = progress(t)
                k = int(np.clip(np.searchsorted(cum, u, side="right") - 1, 0, max(n_seg - 1, 0)))
                if n_seg == 0:
                    q, qd = path[-1], np.zeros(ARM_JOINTS)
                else:
                    a = (u - cum[k]) / seg_t[k]
                    a = min(max(a, 0.0), 1.0)
                    q = path[k] + a * (path[k + 1] - path[k])
                    qd = (path[k + 1] - path[k]) / seg_t[k] * rate
                self.robot.set_arm_target(q, qd)
                self._physics_step(sub == self.substeps - 1)
            self._end_frame()
            if self.halted:  # the task succeeded part-way: hold the arm where it is
                self._hold_q = self.robot.arm_qpos()
                self.robot.set_arm_target(self._hold_q, np.zeros(ARM_JOINTS))
                return
        self._hold_q = path[-1].copy()
        self.robot.set_arm_target(self._hold_q, np.zeros(ARM_JOINTS))
        self.settle()

    def settle(self) -> None:
        """Hold the current target until the arm is at rest (bounded).

        At rest means every joint slower than `rest_speed`; an arm that is blocked and creeps
        (slower than the key-frame rule's 0.1 rad/s, but not at rest) is given 3 frames, so a
        blocked move does not fill the recording with "stopped" frames.
        """
        lim = self.limits
        slow = 0
        for _ in range(lim.settle_frames):
            if self.halted:
                return
            speed = float(np.max(np.abs(self.frame_qvel)))
            slow = slow + 1 if speed < 0.1 else 0
            if speed < lim.rest_speed or slow >= 3:
                return
            self.step_frame()

    def step_frame(self) -> None:
        for sub in range(self.substeps):
            self._physics_step(sub == self.substeps - 1)
        self._end_frame()

    def move_to(self, target: sapien.Pose) -> None:
        """Plan and follow a path to the TCP pose `target` (world frame); raises Unreachable."""
        path = self.plan(target)
        start = self.robot.tcp_pose_at(path[0])
        length = float(np.linalg.norm(np.asarray(target.p) - np.asarray(start.p)))
        angle = quat_angle(np.asarray(start.q), np.asarray(target.q))
        self.follow(path, length, angle)

    def move_joints(self, q1: np.ndarray) -> None:
        """Follow a straight joint-space line to the arm configuration q1."""
        q0 = self._hold_q.copy()
        n = max(1, int(math.ceil(np.max(np.abs(q1 - q0)) / 0.02)))
        start, end = self.robot.tcp_pose_at(q0), self.robot.tcp_pose_at(q1)
        length = float(np.linalg.norm(np.asarray(end.p) - np.asarray(start.p)))
        self.follow(np.linspace(q0, q1, n + 1), length, quat_angle(np.asarray(start.q), np.asarray(end.q)))

    def drive(self, q1: np.ndarray, open_: bool, frames: int) -> None:
        """One control step: command the gripper, then move the arm's drive target linearly from
        the last target to q1 over `frames` frames (velocity target = the line's slope), stepping
        every frame through the frame path (task hooks, recorder, callbacks)."""
        if open_ != self.robot.gripper_open:
            self.robot.set_gripper_target(open_)
        q0 = self._hold_q.copy()
        n = frames * self.substeps
        slope = (q1 - q0) / (n * self.dt)
        for frame in range(frames):
            for sub in range(self.substeps):
                i = frame * self.substeps + sub + 1
                self.robot.set_arm_target(q0 + (q1 - q0) * (i / n), slope)
                self._physics_step(sub == self.substeps - 1)
            self._end_frame()
        self._hold_q = np.array(q1, dtype=float)

    def set_gripper(self, open_: bool) -> None:
        """Open or close the fingers and wait until they stop (fully open/closed, or holding)."""
        if open_ == self.robot.gripper_open:
            return
        releasing = open_ and self.grasp is not None and self.grasp.held is not None
        self.robot.set_gripper_target(open_)
        for i in range(self.limits.gripper_frames):
            self.step_frame()
            width = self.robot.finger_width()
            at_end = width > 2 * 0.04 - 1e-3 if open_ else width < 1e-3
            still = float(np.max(np.abs(self.robot.qvel[ARM_JOINTS:]))) < 0.02
            if self.halted or (i >= 1 and (at_end or still)):
                break
        if releasing and not self.halted:  # as RLBench after opening: a few more frames for the released object to drop
            for _ in range(self.limits.drop_frames):
                self.step_frame()
                if self.halted:
                    break
