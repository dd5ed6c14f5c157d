"""The fixed part of the world: physics scene, floor, table, lights, robot and cameras."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sapien

from .cameras import CAMERA_NAMES, Cameras
from .robot import Panda

TABLE_TOP_Z = 0.75
#: the table: x from -0.55 to 0.85, y from -0.7 to 0.7, top at 0.75 m
TABLE_HALF = (0.70, 0.70, TABLE_TOP_Z / 2)
TABLE_CENTRE = (0.15, 0.0, TABLE_TOP_Z / 2)


@dataclass(frozen=True)
class RobotPlacement:
    """Where the Panda's base (panda_link0) stands, and its arm's start joints."""

    position: tuple[float, float, float]
    quat_wxyz: tuple[float, float, float, float]
    home_qpos: tuple[float, ...]


#: simulator.robot. ours: the base 35 cm behind the grid's x = 0; start TCP at about
#: (0.07, 0.00, 1.25), pointing down. rlbench: RLBench's Panda as RoboVerse recorded it inside
#: RLBench (metasim-core 0.1.0, close_box franka_v2.pkl.gz: the same base pose and start joints in
#: all 100 episodes, z counted from the table top); start TCP at about (0.29, -0.01, 1.45). The
#: frame was checked by posing our Panda at the recorded joints: its fingers meet the recorded lid
#: while the lid closes (docs/AGNOSTOS.md, "Robot placement").
ROBOT_PLACEMENTS = {
    "ours": RobotPlacement((-0.35, 0.0, TABLE_TOP_Z), (1.0, 0.0, 0.0, 0.0), (0.0, -0.43, 0.0, -2.0702, 0.0, 1.6401, np.pi / 4)),
    "rlbench": RobotPlacement(
        (-0.267651, -0.0053, TABLE_TOP_Z + 0.000318),
        (0.999606729, 0.000221563, 0.002819736, -0.006197862),
        (0.0, 0.1752, 0.0, -0.8731, 0.0, 1.2216, 0.7854),
    ),
}
#: (low, high) corner of the box the 100^3 text grid covers (the upstream AGNOSTOS grid)
WORKSPACE = ((-0.3, -0.5, 0.6), (0.7, 0.5, 1.6))
#: RLBench's workspace in z (rlbench/backend/scene.py): from the table top (its `workspace` shape's
#: position) to 1 m above it; targets outside raise InvalidActionError (simulator.workspace_check: rlbench)
RLBENCH_WORKSPACE_Z = (TABLE_TOP_Z, TABLE_TOP_Z + 1.0)


class World:
    """One SAPIEN scene with the table, lights, robot and cameras; the simulator builds one per episode."""

    def __init__(
        self,
        physics_hz: float = 200.0,
        image_size: int | tuple[int, int] = 128,
        cameras=CAMERA_NAMES,
        render: bool = True,
        depth: bool = True,
        segmentation: bool = True,
        robot: str = "ours",
    ):
        self.scene = sapien.Scene()
        self.scene.set_timestep(1.0 / physics_hz)
        self._build_static()
        if render:
            self._build_lights()
        placement = ROBOT_PLACEMENTS[robot]
        self.robot = Panda(self.scene, sapien.Pose(list(placement.position), list(placement.quat_wxyz)), placement.home_qpos)
        self.cameras = (
            Cameras(
                self.scene, list(cameras), image_size, {l.name: l for l in self.robot.links}, depth=depth, segmentation=segmentation
            )
            if render
            else None
        )
        self.static_ids = {self.table.per_scene_id, self.ground.per_scene_id}
        #: the GraspAttacher of `simulator.grasp: attach` (None: objects are held by friction)
        self.grasp = None

    def _build_static(self) -> None:
        floor = sapien.render.RenderMaterial(base_color=[0.45, 0.42, 0.40, 1.0])
        self.ground = self.scene.add_ground(0.0, render_material=floor)
        builder = self.scene.create_actor_builder()
        half = np.array(TABLE_HALF)
        builder.add_box_collision(half_size=half)
        wood = sapien.render.RenderMaterial(base_color=[0.72, 0.58, 0.42, 1.0], roughness=0.8)
        builder.add_box_visual(half_size=half, material=wood)
        builder.set_initial_pose(sapien.Pose(TABLE_CENTRE))
        self.table = builder.build_static(name="table")

    def _build_lights(self) -> None:
        self.scene.set_ambient_light([0.35, 0.35, 0.35])
        self.scene.add_directional_light([0.3, 0.4, -1.0], [0.55, 0.55, 0.55])
        self.scene.add_directional_light([-0.5, -0.2, -0.6], [0.25, 0.25, 0.25])
        self.scene.add_point_light([0.6, 0.0, 2.0], [0.6, 0.6, 0.6])

    def render(self, names=None):
        """Pictures of the named cameras (all by default) at the current state."""
        if self.cameras is None:
            raise RuntimeError("this simulator was created with render=False")
        self.scene.update_render()
        return self.cameras.capture(names)
