"""The Franka Panda: loading, joint drives, TCP frame, gripper state and IK model."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import sapien

ASSET_DIR = Path(__file__).parent / "assets" / "panda"
URDF = ASSET_DIR / "panda_v2.urdf"

ARM_JOINTS = 7
FINGER_OPEN = 0.04  # metres per finger (the joint limit)
# drive targets beyond the joint limits: the fingers get there fast and a grasp keeps squeezing
FINGER_OPEN_TARGET = 0.05
FINGER_CLOSED_TARGET = -0.01
#: TCP orientation (w, x, y, z) that points the gripper straight down, fingers closing along world y.
GRIPPER_DOWN_WXYZ = (0.0, 1.0, 0.0, 0.0)
TCP_LINK = "panda_hand_tcp"
FINGER_LINKS = ("panda_leftfinger", "panda_rightfinger")

# PD gains. Gravity is switched off on the robot's links (exact compensation of its own weight).
ARM_STIFFNESS, ARM_DAMPING = 4000.0, 400.0
ARM_FORCE_LIMITS = np.array([87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0]) * 2.0
FINGER_STIFFNESS, FINGER_DAMPING, FINGER_FORCE_LIMIT = 2000.0, 100.0, 60.0


class Panda:
    """A fixed-base Panda standing on the table at `base_pose`, starting at `home_qpos`."""

    def __init__(self, scene: sapien.Scene, base_pose: sapien.Pose, home_qpos):
        self.home_qpos = np.array(home_qpos, dtype=float)
        loader = scene.create_urdf_loader()
        loader.fix_root_link = True
        for name in FINGER_LINKS:
            loader.set_link_material(name, 2.0, 2.0, 0.0)  # grippy finger pads
        self.articulation = loader.load(str(URDF))
        self.articulation.set_name("panda")
        self.articulation.set_root_pose(base_pose)
        self.base_pose = base_pose
        self.links = self.articulation.get_links()
        self.link_names = [link.name for link in self.links]
        self.joints = self.articulation.get_active_joints()
        self.tcp_index = self.link_names.index(TCP_LINK)
        self.tcp = self.links[self.tcp_index]
        self.fingers = [self.links[self.link_names.index(n)] for n in FINGER_LINKS]
        self.entity_ids = {link.entity.per_scene_id for link in self.links}
        self.qlimits = self.articulation.get_qlimits()[:ARM_JOINTS].copy()
        self.articulation.set_solver_position_iterations(20)
        self.articulation.set_solver_velocity_iterations(2)
        for link in self.links:
            link.disable_gravity = True
        for i, joint in enumerate(self.joints[:ARM_JOINTS]):
            joint.set_drive_property(ARM_STIFFNESS, ARM_DAMPING, float(ARM_FORCE_LIMITS[i]))
        for joint in self.joints[ARM_JOINTS:]:
            joint.set_drive_property(FINGER_STIFFNESS, FINGER_DAMPING, FINGER_FORCE_LIMIT)
        self.pinocchio = self.articulation.create_pinocchio_model()
        self.gripper_open = True
        self.reset()

    # --- state -----------------------------------------------------------------------------
    def reset(self, arm_qpos: np.ndarray | None = None) -> None:
        arm = self.home_qpos if arm_qpos is None else np.asarray(arm_qpos, dtype=float)
        qpos = np.concatenate([arm, [FINGER_OPEN, FINGER_OPEN]])
        self.articulation.set_qpos(qpos)
        self.articulation.set_qvel(np.zeros_like(qpos))
        self.set_arm_target(arm, np.zeros(ARM_JOINTS))
        self.set_gripper_target(True)

    @property
    def qpos(self) -> np.ndarray:
        return self.articulation.get_qpos()

    @property
    def qvel(self) -> np.ndarray:
        return self.articulation.get_qvel()

    def arm_qpos(self) -> np.ndarray:
        return self.articulation.get_qpos()[:ARM_JOINTS].copy()

    def finger_width(self) -> float:
        return float(np.sum(self.articulation.get_qpos()[ARM_JOINTS:]))

    def tcp_pose(self) -> sapien.Pose:
        return self.tcp.entity_pose

    def in_base(self, pose: sapien.Pose) -> np.ndarray:
        """A world pose as xyz + wxyz (w >= 0) in the robot base frame."""
        local = self.base_pose.inv() * pose
        q = np.asarray(local.q, dtype=np.float64)
        return np.concatenate([np.asarray(local.p, dtype=np.float64), -q if q[0] < 0 else q])

    # --- commands --------------------------------------------------------------------------
    def set_arm_target(self, q: np.ndarray, qd: np.ndarray | None = None) -> None:
        self.arm_target = np.array(q[:ARM_JOINTS], dtype=float)  # the last commanded target
        for i, joint in enumerate(self.joints[:ARM_JOINTS]):
            joint.set_drive_target(float(q[i]))
            joint.set_drive_velocity_target(0.0 if qd is None else float(qd[i]))

    def set_gripper_target(self, open_: bool) -> None:
        self.gripper_open = bool(open_)
        target = FINGER_OPEN_TARGET if open_ else FINGER_CLOSED_TARGET
        for joint in self.joints[ARM_JOINTS:]:
            joint.set_drive_target(target)

    # --- kinematics ------------------------------------------------------------------------
    def tcp_pose_at(self, arm_q: np.ndarray) -> sapien.Pose:
        """World TCP pose for arm joint positions (fingers do not move the TCP)."""
        q = np.concatenate([arm_q, [FINGER_OPEN, FINGER_OPEN]])
        self.pinocchio.compute_forward_kinematics(q)
        return self.base_pose * self.pinocchio.get_link_pose(self.tcp_index)

    def unwrap(self, q: np.ndarray, seed_q: np.ndarray) -> np.ndarray:
        """Revolute joints 1, 3, 5, 7 may have wrapped by 2*pi; bring them back near the seed."""
        for j in (0, 2, 4, 6):
            while q[j] - seed_q[j] > np.pi and q[j] - 2 * np.pi >= self.qlimits[j, 0]:
                q[j] -= 2 * np.pi
            while seed_q[j] - q[j] > np.pi and q[j] + 2 * np.pi <= self.qlimits[j, 1]:
                q[j] += 2 * np.pi
        return q

    def ik_masked(self, target: sapien.Pose, seed_q: np.ndarray, mask: np.ndarray, iterations: int = 200):
        """(arm joints, converged) solving only the arm joints where mask is 1; no limit check, no unwrapping."""
        seed = np.concatenate([seed_q, [FINGER_OPEN, FINGER_OPEN]])
        q, ok, _err = self.pinocchio.compute_inverse_kinematics(
            self.tcp_index,
            self.base_pose.inv() * target,
            initial_qpos=seed,
            active_qmask=np.concatenate([np.asarray(mask, dtype=np.int32), [0, 0]]).astype(np.int32),
            eps=1e-5,
            max_iterations=iterations,
        )
        return self.unwrap(np.asarray(q[:ARM_JOINTS], dtype=float), seed_q), bool(ok)

    def ik(self, target: sapien.Pose, seed_q: np.ndarray, iterations: int = 200) -> np.ndarray | None:
        """Arm joint positions that put the TCP at the world pose `target`, or None."""
        seed = np.concatenate([np.clip(seed_q, self.qlimits[:, 0], self.qlimits[:, 1]), [FINGER_OPEN, FINGER_OPEN]])
        q, ok, _err = self.pinocchio.compute_inverse_kinematics(
            self.tcp_index,
            self.base_pose.inv() * target,
            initial_qpos=seed,
            active_qmask=np.array([1] * ARM_JOINTS + [0, 0], dtype=np.int32),
            eps=1e-5,
            max_iterations=iterations,
        )
        if not ok:
            return None
        q = self.unwrap(np.asarray(q[:ARM_JOINTS], dtype=float), seed_q)
        margin = 1e-3
        if np.any(q < self.qlimits[:, 0] - margin) or np.any(q > self.qlimits[:, 1] + margin):
            return None
        return np.clip(q, self.qlimits[:, 0], self.qlimits[:, 1])
