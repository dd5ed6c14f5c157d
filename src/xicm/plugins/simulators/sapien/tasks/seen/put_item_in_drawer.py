"""put_item_in_drawer (seen).

Task description:
    A closed three-drawer cabinet stands on the table facing the robot, and an item (a 4 cm
    block) lies on the table near the robot, out of the drawers' way. The robot pulls the
    named drawer open by its handle, lets go, picks the item up and drops it into the open
    drawer.

Randomisations:
    - the drawer (variation 0: top, 1: middle, 2: bottom) when variations are sampled;
    - cabinet centre x in [0.48, 0.56] m, y in [-0.12, 0.12] m and yaw in [-22.5, 22.5] degrees
      (as in open_drawer);
    - the item anywhere in x in [0.00, 0.10] m, y in [-0.36, 0.36] m (near the robot) with a
      random yaw, at least 8 cm clear of the space a pulled-out drawer and its handle take.

Success conditions:
    The item lies inside the named drawer (its centre within the drawer's tray, below the
    top of the drawer's front).
"""

from __future__ import annotations

import numpy as np
import sapien


from ...objects import add_box, physical
from ...scene import TABLE_TOP_Z
from ...task_base import quantised
from .open_drawer import (
    DEPTH,
    HANDLE_OUT,
    POSITIONS,
    SLOT,
    WALL,
    WIDTH,
    OpenDrawer,
)

HALF = 0.02  # the item is a 4 cm cube
PULL = 0.23
INNER_W = WIDTH / 2 - WALL - 0.004  # drawer tray half width (as built by OpenDrawer)
INNER_D = DEPTH / 2 - WALL - 0.01  # drawer tray half depth
DRAWER_H = SLOT / 2 - 0.008
DOWN = np.array([0.0, 1.0, 0.0, 0.0])
ITEM_X, ITEM_Y = (0.0, 0.10), (-0.36, 0.36)


def down_yaw(yaw: float) -> np.ndarray:
    """Gripper pointing down, turned by `yaw` about the world z axis."""
    return np.asarray((sapien.Pose(q=[np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)]) * sapien.Pose(q=DOWN)).q)


def fold_yaw(yaw: float) -> float:
    """The yaw in [-45, 45) degrees that grips a square face pair of something at `yaw`."""
    return (yaw + np.pi / 4) % (np.pi / 2) - np.pi / 4


class PutItemInDrawer(OpenDrawer):
    name = "put_item_in_drawer"
    max_control_steps = 208  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "seen"
    instruction = "put the item in the top drawer"
    phrasings = (  # RLBench's variation-0 phrasings, AGNOSTOS's instruction first
        "put the item in the top drawer",
        "put the block away in the top drawer",
        "open the top drawer and place the block inside of it",
        "leave the block in the top drawer",
    )
    object_names = ("item", "top drawer handle", "middle drawer handle", "bottom drawer handle")

    def load(self) -> None:
        super().load()
        b = self.world.scene.create_actor_builder()
        add_box(b, [HALF] * 3, color=(0.95, 0.50, 0.05), material=physical(1.2), density=600.0)
        self.item = self.objects.actor(b, "item")
        self.drawers = [self.cabinet.find_link_by_name(f"{p}_drawer") for p in POSITIONS]

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        super().initialise(rng, sample_variation)  # drawer, cabinet pose
        self.episode_instruction = f"put the item in the {POSITIONS[self.variation]} drawer"
        root = self.cabinet.get_root_pose()
        while True:  # on the table near the robot, clear of the drawers' path and the arm's way to them
            spot = np.array([rng.uniform(*ITEM_X), rng.uniform(*ITEM_Y), TABLE_TOP_Z + HALF])
            yaw = rng.uniform(-np.pi, np.pi)
            local = (root.inv() * sapien.Pose(spot)).p
            if local[0] < -DEPTH / 2 - PULL - HANDLE_OUT - 0.08 or abs(local[1]) > WIDTH / 2 + 0.08:
                break
        self.item.set_pose(sapien.Pose(spot, [np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)]))

    def in_drawer(self, index: int) -> bool:
        """Whether the item's centre is inside the tray of drawer `index`."""
        local = (self.drawers[index].entity_pose.inv() * self.item.pose).p
        inside_xy = -2 * INNER_D < local[0] < 0.0 and abs(local[1]) < INNER_W
        return bool(inside_xy and -DRAWER_H < local[2] < DRAWER_H)

    def evaluate(self) -> bool:
        return self.in_drawer(self.variation)

    def demonstration(self):
        rot, out, _, _, _ = self.handle_grasp()
        # 1. pull the named drawer open and let go of the handle
        yield from self.pull_keys(release=True)
        held = np.asarray(self.world.robot.tcp_pose().p, dtype=float)
        retreat = held + out * 0.10 + [0.0, 0.0, 0.10]  # straight out of the handle, then up
        cab_yaw = np.arctan2(rot[1, 0], rot[0, 0])
        drop_q = down_yaw(fold_yaw(cab_yaw))
        yield quantised(self.key(retreat, drop_q, True))  # turning the gripper to point down
        # 2. pick the item up; travel above the open drawer's front
        drawer = self.drawers[self.variation].entity_pose
        front_top = self.world_point(drawer, [0.0, 0.0, DRAWER_H + 0.004])[2]
        item = self.item.pose
        grip_q = down_yaw(fold_yaw(2 * np.arctan2(item.q[3], item.q[0])))
        pick = np.asarray(item.p, dtype=float) + [0.0, 0.0, HALF - 0.012]
        carry = max(front_top + 0.06 + 2 * HALF, pick[2] + 0.12, retreat[2])
        yield quantised(self.key([*pick[:2], carry], grip_q, True))
        yield quantised(self.key(pick, grip_q, False))
        in_hand = np.asarray(self.world.robot.tcp_pose().p, dtype=float) - np.asarray(self.item.pose.p, dtype=float)
        # 3. drop it into the open tray, just behind the drawer's front (the hand stays clear of
        #    the cabinet and of the handles above)
        drawer = self.drawers[self.variation].entity_pose
        floor = -DRAWER_H + 0.008
        drop = self.world_point(drawer, [-0.06, 0.0, floor + HALF + 0.007]) + in_hand
        yield quantised(self.key([*pick[:2], carry], grip_q, False))
        yield quantised(self.key([*drop[:2], carry], drop_q, False))
        yield quantised(self.key(drop, drop_q, True))
        yield quantised(self.key(drop + [0, 0, 0.10], drop_q, True))
