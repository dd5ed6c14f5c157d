"""Building task objects from boxes and cylinders, and remembering which object each entity is."""

from __future__ import annotations

import numpy as np
import sapien

COLORS = {
    "red": (0.85, 0.10, 0.10),
    "green": (0.10, 0.70, 0.15),
    "blue": (0.10, 0.25, 0.90),
    "yellow": (0.95, 0.85, 0.10),
    "orange": (0.95, 0.50, 0.05),
    "purple": (0.55, 0.15, 0.70),
    "white": (0.95, 0.95, 0.95),
    "black": (0.05, 0.05, 0.05),
    "cyan": (0.10, 0.80, 0.85),
    "magenta": (0.90, 0.10, 0.70),
}


def look(rgb, roughness: float = 0.6, metallic: float = 0.0) -> sapien.render.RenderMaterial:
    """A plain render material of colour `rgb` (name from COLORS or an RGB triple)."""
    if isinstance(rgb, str):
        rgb = COLORS[rgb]
    return sapien.render.RenderMaterial(base_color=[*rgb, 1.0], roughness=roughness, metallic=metallic)


def physical(friction: float = 1.0) -> sapien.physx.PhysxMaterial:
    return sapien.physx.PhysxMaterial(friction, friction, 0.0)


def _material(color) -> sapien.render.RenderMaterial:
    return color if isinstance(color, sapien.render.RenderMaterial) else look(color)


def add_box(builder, half_size, pose=None, color=(0.7, 0.7, 0.7), material=None, density=500.0, collide=True):
    """A box (collision + visual, or visual only with collide=False) on an actor or link builder."""
    pose = pose or sapien.Pose()
    if collide:
        builder.add_box_collision(pose=pose, half_size=half_size, material=material, density=density)
    builder.add_box_visual(pose=pose, half_size=half_size, material=_material(color))


_AXIS_TURN = {  # SAPIEN cylinders run along their local x axis
    "x": sapien.Pose(),
    "y": sapien.Pose(q=[np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)]),
    "z": sapien.Pose(q=[np.cos(np.pi / 4), 0, -np.sin(np.pi / 4), 0]),
}


def add_cylinder(
    builder, radius, half_length, pose=None, color=(0.7, 0.7, 0.7), material=None, density=500.0, axis="z", collide=True
):
    """A cylinder along the local `axis` ('x', 'y' or 'z') of `pose`."""
    pose = (pose or sapien.Pose()) * _AXIS_TURN[axis]
    if collide:
        builder.add_cylinder_collision(
            pose=pose, radius=radius, half_length=half_length, material=material, density=density
        )
    builder.add_cylinder_visual(pose=pose, radius=radius, half_length=half_length, material=_material(color))


def yaw_pose(x: float, y: float, z: float, yaw: float) -> sapien.Pose:
    return sapien.Pose([x, y, z], [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])


class ObjectSet:
    """The task objects currently in the scene and the object name of every entity."""

    def __init__(self, scene: sapien.Scene):
        self.scene = scene
        self.segment_names: dict[int, str] = {}
        self.actors: list[sapien.Entity] = []
        self.articulations: list[sapien.physx.PhysxArticulation] = []
        #: entity ids of the dynamic actors (the default graspable objects of a task)
        self.movable_ids: set[int] = set()

    def actor(self, builder, object_name: str, kind: str = "dynamic", pose: sapien.Pose | None = None) -> sapien.Entity:
        builder.set_name(object_name)
        if pose is not None:
            builder.set_initial_pose(pose)
        entity = {"dynamic": builder.build, "static": builder.build_static, "kinematic": builder.build_kinematic}[kind](
            name=object_name
        )
        self.actors.append(entity)
        self.segment_names[entity.per_scene_id] = object_name
        if kind == "dynamic":
            self.movable_ids.add(entity.per_scene_id)
        return entity

    def articulation(
        self, builder, link_objects: dict[str, str], name: str, pose: sapien.Pose | None = None, fix_root: bool = True
    ):
        """Build an articulation; `link_objects` maps each link name to the object it belongs to.

        fix_root=False leaves the root link free (a loose object made of jointed parts, e.g. a rope)."""
        if pose is not None:
            builder.set_initial_pose(pose)
        art = builder.build(fix_root_link=fix_root)
        art.set_name(name)
        for link in art.get_links():
            self.segment_names[link.entity.per_scene_id] = link_objects.get(link.name, name)
        self.articulations.append(art)
        return art

    def clear(self) -> None:
        for art in self.articulations:
            self.scene.remove_articulation(art)
        for entity in self.actors:
            self.scene.remove_actor(entity)
        self.actors.clear()
        self.articulations.clear()
        self.segment_names.clear()
        self.movable_ids.clear()

    def ids_of(self, object_name: str) -> list[int]:
        return [i for i, n in self.segment_names.items() if n == object_name]
