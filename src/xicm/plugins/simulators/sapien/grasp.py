"""RLBench-style grasping (`simulator.grasp: attach`): a graspable object the closed fingers hold
is fixed to the hand until the gripper is commanded open.

RLBench (PyRep's Gripper.grasp) re-parents an object to the gripper when the fingers close on
it, so a grasp never slips. Here the object is joined to the hand link by a SAPIEN drive
(a PhysX D6 joint): its three linear axes are locked and its rotation is held by a stiff
acceleration-mode slerp drive. A joint, not a kinematic follow, because the held object keeps
colliding with the world at bounded force (a kinematic body would push through a wall and would
need a new pose every physics substep). Angular limits are not used: in SAPIEN 3.0.3 a zero-width
twist/cone/pyramid limit left the rotation free in a probe, while the locked linear limits held.

`update()` runs once per control frame (Controller._end_frame), in key-action moves and in
per-step control alike.
"""

from __future__ import annotations

import sapien

from .robot import Panda

HAND_LINK = "panda_hand"
#: below this finger opening (m) the fingers touch each other, so an object touching both is
#: against their outsides, not between them
MIN_WIDTH = 0.002
#: slerp drive of the held object's rotation, in acceleration mode (independent of its mass)
ANGULAR_STIFFNESS, ANGULAR_DAMPING = 1e6, 2e3


class GraspAttacher:
    """Attaches the graspable object between the closed fingers to the hand; releases it on open."""

    def __init__(self, scene: sapien.Scene, robot: Panda):
        self.scene = scene
        self.robot = robot
        self.hand = robot.links[robot.link_names.index(HAND_LINK)]
        self.graspable: set[int] = set()
        self.held: sapien.Entity | None = None
        self._drive: sapien.physx.PhysxDriveComponent | None = None

    def reset(self, graspable: set[int]) -> None:
        """Forget the held object (the scene's task objects were rebuilt) and take the new
        graspable entity ids."""
        self.graspable = set(graspable)
        self.held = None
        self._drive = None

    @property
    def held_ids(self) -> set[int]:
        return set() if self.held is None else {self.held.per_scene_id}

    def update(self) -> None:
        if self.robot.gripper_open:
            if self.held is not None:
                self.release()
            return
        if self.held is None and self.robot.finger_width() > MIN_WIDTH:
            entity = self._between_fingers()
            if entity is not None:
                self.attach(entity)

    def _between_fingers(self) -> sapien.Entity | None:
        """The graspable entity both fingers press on (lowest id first, for determinism)."""
        fingers = [f.entity for f in self.robot.fingers]
        touched: list[dict[int, sapien.Entity]] = [{}, {}]
        for contact in self.scene.get_contacts():
            if not any(abs(p.impulse).sum() > 1e-6 for p in contact.points):
                continue
            a, b = contact.bodies[0].entity, contact.bodies[1].entity
            for k, finger in enumerate(fingers):
                other = b if a is finger else a if b is finger else None
                if other is not None and other.per_scene_id in self.graspable:
                    touched[k][other.per_scene_id] = other
        common = sorted(set(touched[0]) & set(touched[1]))
        return touched[0][common[0]] if common else None

    def attach(self, entity: sapien.Entity) -> None:
        body = entity.find_component_by_type(sapien.physx.PhysxRigidBaseComponent)
        in_hand = self.hand.entity_pose.inv() * entity.pose
        drive = self.scene.create_drive(self.hand, in_hand, body, sapien.Pose())
        for lock in (drive.set_limit_x, drive.set_limit_y, drive.set_limit_z):
            lock(0.0, 0.0)
        drive.set_drive_property_slerp(ANGULAR_STIFFNESS, ANGULAR_DAMPING, mode="acceleration")
        self.held, self._drive = entity, drive

    def release(self) -> None:
        if self.held is not None and self._drive is not None:
            self.held.remove_component(self._drive)
        self.held = None
        self._drive = None
