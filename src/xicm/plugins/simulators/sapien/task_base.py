"""The base class of SAPIEN tasks.

A task builds its objects (`load`), samples an episode from a seeded generator (`initialise`),
says whether it is solved (`evaluate`), may watch every frame (`on_frame`, e.g. for
"pressed in order" conditions) and yields the key actions of its scripted demonstrator
(`demonstration`), computed from the true object state and executed by the same controller
that executes the agent's actions.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar, Iterator

import numpy as np
import sapien

from xicm.core.contracts.types import KeyAction

from .objects import ObjectSet, yaw_pose
from .robot import GRIPPER_DOWN_WXYZ
from .scene import World


def frame_quat(x_axis, y_axis, z_axis) -> np.ndarray:
    """Quaternion (w, x, y, z) of the rotation whose columns are the given unit axes."""
    mat = np.eye(4)
    mat[:3, :3] = np.stack([x_axis, y_axis, z_axis], axis=1)
    return np.asarray(sapien.Pose(mat).q, dtype=float)


def turn_gripper(quat_wxyz) -> np.ndarray:
    """The same gripper pose turned 180 degrees about the gripper axis (fingers swapped)."""
    return np.asarray((sapien.Pose(q=np.asarray(quat_wxyz, dtype=float)) * sapien.Pose(q=[0.0, 0.0, 0.0, 1.0])).q)


def needs_turn(quat_wxyz) -> bool:
    """Whether `turn_gripper` gives the wrist-friendlier of the two equivalent grasps.

    The friendlier one has its hand x axis leaning towards world +x / +z (at the start pose
    hand x is world +x), which keeps the Panda's last joint near the middle of its range.
    Decide once per demonstration and apply it to every pose, so the wrist never flips mid-way.
    """
    x_axis = sapien.Pose(q=np.asarray(quat_wxyz, dtype=float)).to_transformation_matrix()[:3, 0]
    return bool(x_axis[0] + x_axis[2] < 0)


def wrist_friendly(quat_wxyz) -> np.ndarray:
    """The wrist-friendlier of a gripper orientation and its 180-degree turn (see needs_turn)."""
    return turn_gripper(quat_wxyz) if needs_turn(quat_wxyz) else np.asarray(quat_wxyz, dtype=float)


class Task(ABC):
    """A task's class attributes are its only record of name, split, instruction and objects:
    the registry reads them (xicm.core.contracts.types.TaskInfo.of) without building a simulator."""

    #: the registered name (a built-in task's module is named after it)
    name: ClassVar[str]
    split: ClassVar[str]  # 'seen', 'level1' or 'level2'
    #: instruction of variation 0 (what unseen tasks are evaluated on)
    instruction: ClassVar[str]
    #: the objects described to the LLM, in prompt order
    object_names: ClassVar[tuple[str, ...]]
    #: control steps a per-step policy gets by default: ceil(2 x the longest scripted demo
    #: measured by benchmarks/demo_lengths.py at control_hz 10), see docs/DESIGN.md
    max_control_steps: ClassVar[int]
    #: every phrasing of variation 0 (the instruction first; RLBench's list), for
    #: benchmark.instructions: sampled; empty: the instruction only
    phrasings: ClassVar[tuple[str, ...]] = ()
    #: object names the gripper attaches in `simulator.grasp: attach` (RLBench's
    #: register_graspable_objects); None: every dynamic actor of the task
    graspable_objects: ClassVar[tuple[str, ...] | None] = None

    def __init__(self, world: World, objects: ObjectSet):
        self.world = world
        self.objects = objects
        self.variation = 0
        self.episode_instruction = self.instruction
        #: `simulator.success_check: per_frame`: conditions RLBench checks in order (an ordered
        #: ConditionSet) keep each one met once it was (see ordered())
        self.latching = False
        self._met_in_order: dict[str, int] = {}
        #: which randomisation ranges initialise() draws from: "ours" or "rlbench" (span())
        self.ranges = "ours"

    # --- to implement ----------------------------------------------------------------------
    @abstractmethod
    def load(self) -> None:
        """Create the task's objects in the scene (register them in self.objects)."""

    @abstractmethod
    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        """Place the objects and pick the variation for one episode."""

    @abstractmethod
    def evaluate(self) -> bool:
        """Whether the task is solved in the current state."""

    def on_frame(self) -> None:
        """Called after every frame (override to track events)."""

    def on_step_end(self) -> None:
        """Called at the end of every key action or control step, before its success is read
        (override for checks RLBench makes only there, such as a task's fail conditions)."""

    @abstractmethod
    def demonstration(self) -> Iterator[KeyAction]:
        """Key actions of the scripted demonstrator, computed from the true state as it goes."""

    # --- helpers ---------------------------------------------------------------------------
    def span(self, ours: tuple[float, float], rlbench: tuple[float, float]) -> tuple[float, float]:
        """The (low, high) range in effect: this task's own, or RLBench's (simulator.scenes)."""
        return rlbench if self.rlbench_scenes else ours

    @property
    def rlbench_scenes(self) -> bool:
        """Whether RLBench's own layout and success rule apply where a task differs from it
        (simulator.scenes: rlbench); under ours the task keeps its own."""
        return self.ranges == "rlbench"

    def joint_moved(self, start: float, now: float, threshold: float, direction: int) -> bool:
        """Whether a joint moved by more than `threshold` from `start`: under RLBench's scenes
        as its JointCondition, |now - start| either way; under ours only in `direction`
        (+1: opening, -1: closing)."""
        if self.rlbench_scenes:
            return abs(now - start) > threshold
        return direction * (now - start) > threshold

    def turn_base(self, rng: np.random.Generator, entities, pivot_xy) -> float:
        """Under RLBench's ranges, turn `entities` together by a yaw drawn from ±180 degrees (the
        default of RLBench's `base_rotation_bounds`) about the vertical axis through pivot_xy, as
        RLBench turns a task's base with all its objects; returns the yaw (radians, 0 under ours).
        Call it after every other draw of initialise(): under ours it draws nothing, so the
        task's scenes under ours stay what they were."""
        if not self.rlbench_scenes:
            return 0.0
        yaw = float(np.deg2rad(rng.uniform(-180.0, 180.0)))
        turn = yaw_pose(pivot_xy[0], pivot_xy[1], 0.0, yaw) * sapien.Pose([-pivot_xy[0], -pivot_xy[1], 0.0])
        for entity in entities:
            entity.set_pose(turn * entity.pose)
        return yaw

    def ordered(self, name: str, *conditions) -> bool:
        """Whether the `conditions` (callables) hold in order, as RLBench's ConditionSet with
        order_matters: with `latching` each one stays met once it was, in the order given (a
        later one counts only after the earlier ones); without it they must all hold now."""
        if not self.latching:
            return all(c() for c in conditions)
        done = self._met_in_order.get(name, 0)
        while done < len(conditions) and conditions[done]():
            done += 1
        self._met_in_order[name] = done
        return done == len(conditions)

    @staticmethod
    def key(position, quat_wxyz=GRIPPER_DOWN_WXYZ, gripper_open: bool = True) -> KeyAction:
        p = np.asarray(position, dtype=float)
        q = np.asarray(quat_wxyz, dtype=float)
        q = q / np.linalg.norm(q)
        return KeyAction(tuple(float(v) for v in p), tuple(float(v) for v in q), bool(gripper_open))

    @staticmethod
    def world_point(pose: sapien.Pose, local) -> np.ndarray:
        return np.asarray((pose * sapien.Pose(local)).p, dtype=float)

    def graspable_ids(self) -> set[int]:
        """Entity ids of the objects `simulator.grasp: attach` may attach to the hand."""
        if self.graspable_objects is None:
            return set(self.objects.movable_ids)
        return {i for name in self.graspable_objects for i in self.objects.ids_of(name)}

    def grasped(self) -> set[int]:
        """Entity ids that both fingers currently touch or that are attached to the hand
        (what the gripper is holding)."""
        held = set() if self.world.grasp is None else self.world.grasp.held_ids
        return held | self._squeezed()

    def _squeezed(self) -> set[int]:
        fingers = [f.entity for f in self.world.robot.fingers]
        touched: list[set[int]] = [set(), set()]
        for contact in self.world.scene.get_contacts():
            ents = [contact.bodies[0].entity, contact.bodies[1].entity]
            if not any(abs(p.impulse).sum() > 1e-6 for p in contact.points):
                continue
            for k, finger in enumerate(fingers):
                if ents[0] is finger:
                    touched[k].add(ents[1].per_scene_id)
                elif ents[1] is finger:
                    touched[k].add(ents[0].per_scene_id)
        return touched[0] & touched[1]


def snap_to_grid(p) -> np.ndarray:
    """The centre of the text-grid voxel holding p: a key pose there survives the 7-integer text exactly."""
    from xicm.core.text import encoding

    from .scene import WORKSPACE

    return np.asarray(encoding.voxel_to_position(encoding.position_to_voxel(p, WORKSPACE), WORKSPACE))


def quantised(action: KeyAction) -> KeyAction:
    """The action as the LLM sees it (1 cm, 5 degree bins), so a demo replays exactly."""
    from xicm.core.text import encoding

    from .scene import WORKSPACE

    return encoding.quantise(action, WORKSPACE)


def down_quat(theta: float) -> np.ndarray:
    """Gripper pointing straight down with its x axis at yaw `theta`."""
    x = np.array([np.cos(theta), np.sin(theta), 0.0])
    z = np.array([0.0, 0.0, -1.0])
    return frame_quat(x, np.cross(z, x), z)


def yaw_of(pose: sapien.Pose) -> float:
    """Rotation of a pose about the world z axis."""
    m = pose.to_transformation_matrix()
    return float(np.arctan2(m[1, 0], m[0, 0]))



def half_turn(angle: float) -> float:
    """The angle modulo 180 degrees, in [-90, 90) degrees (radians): a symmetric gripper's yaw."""
    return float((angle + np.pi / 2) % np.pi - np.pi / 2)


def door_push_pose(root: sapien.Pose, hinge_xy, theta: float, radius: float, height: float, standoff: float, turn=None):
    """(TCP position, quaternion, turn) for pushing a door shut with the side of the closed fingers.

    The door hangs on a vertical hinge at `hinge_xy` (object frame, the door extending along -y
    when closed) and is open by `theta`; the TCP is `radius` from the hinge along the door, at
    `height` above the object's base, `standoff` off the door's mid-plane on its outer side.
    `turn` (None: decide by `needs_turn`) is returned so a demo keeps one wrist choice throughout.
    """
    along = np.array([-np.sin(theta), -np.cos(theta)])  # hinge -> free edge
    normal = np.array([-np.cos(theta), np.sin(theta)])  # outer face normal
    xy = np.asarray(hinge_xy, dtype=float) + radius * along + normal * standoff
    rot = root.to_transformation_matrix()[:3, :3]
    push_dir = rot @ np.array([-normal[0], -normal[1], 0.0])  # a flat side of the fingers pushes
    down = np.array([0.0, 0.0, -1.0])
    quat = frame_quat(push_dir, np.cross(down, push_dir), down)
    if turn is None:
        turn = needs_turn(quat)
    position = np.asarray((root * sapien.Pose([xy[0], xy[1], height])).p, dtype=float)
    return position, turn_gripper(quat) if turn else quat, turn


def lid_push_point(root: sapien.Pose, hinge_xz, theta: float, r: float, standoff: float) -> np.ndarray:
    """World point `standoff` off a lid's outer face, `r` from its hinge, the lid open by `theta`.

    The lid is hinged about the object's y axis at (x, z) = `hinge_xz` and, when shut
    (theta = 0), lies flat extending along -x (towards the robot when the object faces it).
    """
    along = np.array([-np.cos(theta), 0.0, np.sin(theta)])  # hinge -> free edge
    normal = np.array([np.sin(theta), 0.0, np.cos(theta)])  # outer face normal
    local = np.array([hinge_xz[0], 0.0, hinge_xz[1]]) + r * along + normal * standoff
    return np.asarray((root * sapien.Pose(local)).p, dtype=float)


def push_lid_shut(root: sapien.Pose, hinge_xz, thickness: float, theta0: float, push_r: float, gap: float, first_step: float):
    """Key actions closing a raised lid with the closed fingers: behind and above its free edge,
    push it over the vertical (past it the lid falls shut by itself), then press it down."""
    rot = root.to_transformation_matrix()[:3, :3]
    towards_robot = -rot[:, 0]
    down = np.array([0.0, 0.0, -1.0])
    quat = wrist_friendly(frame_quat(towards_robot, np.cross(down, towards_robot), down))
    finger_half = 0.009  # half thickness of the closed fingers along the hand's x axis

    def point(theta, r, offset):
        return lid_push_point(root, hinge_xz, theta, r, thickness + offset)

    start = point(theta0, push_r, gap)
    keys = [Task.key(start + [0.0, 0.0, 0.08], quat, False), Task.key(start, quat, False)]
    keys += [Task.key(point(theta, push_r, finger_half + 0.004), quat, False) for theta in (theta0 - first_step, 1.15)]
    shut = point(0.0, 0.11, 0.012)
    keys += [Task.key(shut + [0.0, 0.0, 0.05], quat, False), Task.key(shut, quat, False)]
    return keys


def push_door_shut(push_pose, theta0: float, lift: float, angles) -> list:
    """Key actions closing a vertical door with the side of the closed fingers.

    `push_pose(theta, standoff, turn)` gives (position, quaternion, turn) next to the door open by
    `theta` (see door_push_pose). Start 6 cm off the open door and `lift` above that, then push
    through the door angles `angles`, keeping the first wrist choice throughout.
    """
    finger_half = 0.009  # half thickness of the closed fingers along the hand's x axis
    p, q, turn = push_pose(theta0, 0.06, None)
    keys = [Task.key(p + [0.0, 0.0, lift], q, False), Task.key(p, q, False)]  # above, clear of the door
    for theta in angles:
        p, q, _ = push_pose(theta, finger_half + 0.006, turn)
        keys.append(Task.key(p, q, False))
    return keys
