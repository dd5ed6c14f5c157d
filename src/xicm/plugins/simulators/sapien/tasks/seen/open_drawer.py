"""open_drawer (seen).

Task description:
    A three-drawer cabinet stands on the table with its drawers facing the robot. The robot
    grasps the handle of the named drawer and pulls the drawer out.

Randomisations:
    - the drawer to open (variation 0: top, 1: middle, 2: bottom) when variations are sampled;
    - cabinet centre x in [0.48, 0.56] m, y in [-0.12, 0.12] m and yaw in [-22.5, 22.5] degrees
      (RLBench's base_rotation_bounds).

Success conditions:
    The named drawer is pulled out more than 0.15 m from its closed start position.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, frame_quat, wrist_friendly

POSITIONS = ("top", "middle", "bottom")
DEPTH, WIDTH, PLINTH, SLOT, WALL = 0.26, 0.40, 0.10, 0.12, 0.015
HEIGHT = PLINTH + 3 * SLOT + 0.02
HANDLE_OUT = 0.055  # handle bar centre in front of the drawer front (0.04 m from its face)
BAR_RADIUS = 0.008
PITCH = np.deg2rad(60.0)  # the gripper points into the cabinet and 60 degrees down
PULL = 0.21  # how far the demonstrator pulls
SUCCESS_TRAVEL = 0.15


def _slot_centre_z(index: int) -> float:
    """Height above the cabinet's base of the middle of slot `index` (0 = top)."""
    return PLINTH + (2 - index + 0.5) * SLOT


class OpenDrawer(Task):
    name = "open_drawer"
    max_control_steps = 50  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "seen"
    instruction = "open the top drawer"
    phrasings = (  # RLBench's variation-0 phrasings, AGNOSTOS's instruction first
        "open the top drawer",
        "grip the top handle and pull the top drawer open",
        "slide the top drawer open",
    )
    object_names = ("top drawer handle", "middle drawer handle", "bottom drawer handle")

    def load(self) -> None:
        body_col = (0.55, 0.38, 0.22)
        front_col = (0.78, 0.62, 0.42)
        metal = (0.25, 0.25, 0.28)
        ab = self.world.scene.create_articulation_builder()
        body = ab.create_link_builder()
        body.set_name("cabinet")
        hx, hy = DEPTH / 2, WIDTH / 2
        add_box(body, [hx, hy, PLINTH / 2], sapien.Pose([0, 0, PLINTH / 2]), body_col)  # plinth
        add_box(body, [hx, hy, 0.01], sapien.Pose([0, 0, HEIGHT - 0.01]), body_col)  # top
        wall_h = (HEIGHT - PLINTH) / 2
        for side in (-1, 1):
            add_box(body, [hx, WALL / 2, wall_h], sapien.Pose([0, side * (hy - WALL / 2), PLINTH + wall_h]), body_col)
        add_box(body, [WALL / 2, hy, wall_h], sapien.Pose([hx - WALL / 2, 0, PLINTH + wall_h]), body_col)
        for k in (1, 2):  # dividers between the slots
            add_box(body, [hx - WALL, hy - WALL, 0.004], sapien.Pose([0.0, 0, PLINTH + k * SLOT]), body_col)

        links = {"cabinet": "cabinet"}
        inner_w = WIDTH / 2 - WALL - 0.004  # drawer half width
        inner_d = DEPTH / 2 - WALL - 0.01  # drawer half depth
        drawer_h = SLOT / 2 - 0.008
        for i, pos in enumerate(POSITIONS):
            drawer = ab.create_link_builder(body)
            drawer.set_name(f"{pos}_drawer")
            drawer.set_joint_name(f"{pos}_drawer_joint")
            # joint frame x axis points out of the cabinet (-x), so q > 0 means "pulled out"
            out = sapien.Pose([-hx, 0, _slot_centre_z(i)], [0, 0, 0, 1])
            drawer.set_joint_properties("prismatic", [[0.0, 0.25]], out, sapien.Pose(), friction=0.0, damping=8.0)
            # the drawer in its own frame: +x points out of the cabinet, origin at the cabinet front
            wall_z = -drawer_h * 0.3  # tray walls are 70 % of the front's height
            front = sapien.Pose([0.0075, 0, 0])
            add_box(drawer, [0.0075, inner_w + 0.003, drawer_h + 0.004], front, front_col)
            add_box(drawer, [inner_d, inner_w, 0.004], sapien.Pose([-inner_d, 0, -drawer_h + 0.004]), front_col)  # floor
            for side in (-1, 1):
                pose = sapien.Pose([-inner_d, side * (inner_w - 0.004), wall_z])
                add_box(drawer, [inner_d, 0.004, drawer_h * 0.7], pose, front_col)
            add_box(drawer, [0.004, inner_w, drawer_h * 0.7], sapien.Pose([-2 * inner_d + 0.004, 0, wall_z]), front_col)
            handle = ab.create_link_builder(drawer)
            handle.set_name(f"{pos}_handle")
            handle.set_joint_name(f"{pos}_handle_joint")
            handle.set_joint_properties("fixed", [], sapien.Pose([0.015, 0, 0]), sapien.Pose())
            grip = physical(1.5)
            bar = HANDLE_OUT - 0.015
            # a vertical bar handle on two short posts
            add_cylinder(handle, BAR_RADIUS, 0.03, sapien.Pose([bar, 0, 0]), metal, material=grip, axis="z")
            for side in (-1, 1):
                add_box(handle, [bar / 2, 0.006, 0.006], sapien.Pose([bar / 2, 0, side * 0.024]), metal)
            links[f"{pos}_drawer"] = f"{pos} drawer"
            links[f"{pos}_handle"] = f"{pos} drawer handle"
        self.cabinet = self.objects.articulation(ab, links, "cabinet")
        self.joints = self.cabinet.get_active_joints()
        self.handles = [self.cabinet.find_link_by_name(f"{p}_handle") for p in POSITIONS]

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        variation = int(rng.integers(3))
        self.variation = variation if sample_variation else 0
        self.episode_instruction = f"open the {POSITIONS[self.variation]} drawer"
        x = rng.uniform(0.48, 0.56)
        y = rng.uniform(-0.12, 0.12)
        yaw = np.deg2rad(rng.uniform(-22.5, 22.5))
        # the cabinet's front (-x local) faces the robot
        self.cabinet.set_root_pose(yaw_pose(x, y, TABLE_TOP_Z, yaw))
        self.cabinet.set_qpos(np.zeros(3))
        self.cabinet.set_qvel(np.zeros(3))
        self.start_q = np.zeros(3)

    def travel(self) -> np.ndarray:
        return self.cabinet.get_qpos() - self.start_q

    def evaluate(self) -> bool:
        return bool(self.travel()[self.variation] > SUCCESS_TRAVEL)

    def handle_grasp(self):
        """(cabinet rotation, out-of-cabinet direction, approach direction, TCP grasp point on the
        named drawer's handle, gripper orientation) for grasping the handle."""
        rot = self.cabinet.get_root_pose().to_transformation_matrix()[:3, :3]
        out = -rot[:, 0]  # out of the cabinet, towards the robot
        # gripper z points into the cabinet and down by PITCH; fingers close horizontally
        approach = -out * np.cos(PITCH) + np.array([0.0, 0.0, -np.sin(PITCH)])
        finger = np.cross([0.0, 0.0, 1.0], out)
        quat = wrist_friendly(frame_quat(np.cross(finger, approach), finger, approach))
        bar = self.world_point(self.handles[self.variation].entity_pose, [HANDLE_OUT - 0.015, 0, 0])
        grasp = bar - approach * 0.004  # a little short of the bar centre: the palm stays clear
        return rot, out, approach, grasp, quat

    def pull_keys(self, release: bool):
        """Approach, grasp and pull the named drawer; open the gripper at the end if `release`."""
        _, out, approach, grasp, quat = self.handle_grasp()
        yield self.key(grasp - approach * 0.10, quat, True)
        yield self.key(grasp, quat, False)
        yield self.key(grasp + out * PULL, quat, release)

    def demonstration(self):
        yield from self.pull_keys(release=False)
