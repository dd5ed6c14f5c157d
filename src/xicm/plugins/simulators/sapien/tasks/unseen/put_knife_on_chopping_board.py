"""put_knife_on_chopping_board (unseen, level 1).

Task description:
    A kitchen knife stands tip down in the slot of a wooden knife block, its black handle
    sticking out of the top; a wooden chopping board lies on the table. The robot grips the
    handle from above, pulls the knife straight up out of the block, carries it hanging over
    the board, tips the gripper forward until the knife points 45 degrees down along the
    board, lowers it until the tip is just above the board and lets go: the knife falls flat,
    pivoting on its tip, and lies on the board.

Randomisations:
    - knife block centre x in [0.05, 0.20] m, |y| in [0.17, 0.28] m (either side), yaw in
      [-180, 180] degrees (RLBench's SpawnBoundary default);
    - chopping board centre x in [0.30, 0.38] m, y in [-0.08, 0.08] m, yaw in [-180, 180]
      degrees, at least 0.25 m from the block.

Success conditions:
    The knife lies on the board (its centre over the board and less than 3 cm above the
    board's top) AND nothing is grasped. With `simulator.success_check: per_frame` the two
    latch in that order, as RLBench's ordered ConditionSet: on the board once, then let go.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, down_quat, frame_quat, half_turn, quantised

# the knife along its local x (butt at -x, tip at +x), blade width along y, thickness along z
HANDLE_L, HANDLE_W, HANDLE_T = 0.08, 0.022, 0.014
BLADE_L, BLADE_W, BLADE_T = 0.11, 0.025, 0.002
KNIFE_HALF = (HANDLE_L + BLADE_L) / 2  # the actor's origin is the knife's middle
BLOCK_HALF = (0.04, 0.05, 0.06)  # knife block half size (x across the slot, y along it, z)
SLOT = (0.003, 0.0175)  # half width and half length of the slot
BOARD_HALF = (0.17, 0.11, 0.01)  # chopping board
GRIP_FROM_BUTT = 0.015  # the TCP this far from the handle's end
DROP = 0.012  # the knife's tip this high above the board when let go
TILT = np.deg2rad(45.0)  # the knife points this far below the horizontal when let go
SPAWN_BLOCK = ((0.05, 0.20), (0.17, 0.28), 180.0)
SPAWN_BOARD = ((0.30, 0.38), (-0.08, 0.08), 180.0)
MIN_GAP = 0.25



class PutKnifeOnChoppingBoard(Task):
    name = "put_knife_on_chopping_board"
    max_control_steps = 122  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "level1"
    instruction = "put the knife on the chopping board"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "put the knife on the chopping board",
        "slide the knife out of the knife block and put it down on the chopping board",
        "place the knife on the chopping board",
        "pick up the knife and leave it on the chopping board",
        "move the knife from the holder to the chopping board",
    )
    object_names = ("knife", "knife block", "chopping board")

    def load(self) -> None:
        scene = self.world.scene
        ab = scene.create_articulation_builder()
        block = ab.create_link_builder()
        block.set_name("block")
        wood = look((0.45, 0.28, 0.15), roughness=0.6)
        (bx, by, bz), (sx, sy) = BLOCK_HALF, SLOT
        side_x = (bx - sx) / 2
        for s in (-1, 1):  # the walls either side of the slot, and its two ends
            add_box(block, [side_x, by, bz], sapien.Pose([s * (sx + side_x), 0, bz]), wood, material=physical(0.3))
            end_y = (by - sy) / 2
            add_box(block, [sx, end_y, bz], sapien.Pose([0, s * (sy + end_y), bz]), wood, material=physical(0.3))
        add_box(block, [sx, sy, 0.001], sapien.Pose([0, 0, 2 * bz - 0.001]), (0.1, 0.07, 0.05), collide=False)
        self.block = self.objects.articulation(ab, {"block": "knife block"}, "knife block")

        ab = scene.create_articulation_builder()
        board = ab.create_link_builder()
        board.set_name("board")
        add_box(board, BOARD_HALF, sapien.Pose([0, 0, BOARD_HALF[2]]), look((0.90, 0.80, 0.58), roughness=0.7),
                material=physical(1.0))
        self.board = self.objects.articulation(ab, {"board": "chopping board"}, "chopping board")

        b = scene.create_actor_builder()
        handle = sapien.Pose([-KNIFE_HALF + HANDLE_L / 2, 0, 0])
        add_box(b, [HANDLE_L / 2, HANDLE_W / 2, HANDLE_T / 2], handle, look((0.08, 0.08, 0.08), roughness=0.5),
                material=physical(1.5), density=900.0)
        blade = sapien.Pose([KNIFE_HALF - BLADE_L / 2, 0, 0])
        steel = look((0.80, 0.80, 0.83), roughness=0.2, metallic=0.9)
        add_box(b, [BLADE_L / 2, BLADE_W / 2, BLADE_T / 2], blade, steel,
                material=physical(0.3), density=7800.0)
        for k in (-1, 1):  # rivets
            rivet = sapien.Pose([-KNIFE_HALF + HANDLE_L / 2 + k * 0.025, 0, 0])
            add_box(b, [0.003, 0.003, HANDLE_T / 2 + 0.0005], rivet, (0.75, 0.75, 0.78), collide=False)
        self.knife = self.objects.actor(b, "knife")

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        (bxs, bys, byaw), (cxs, cys, cyaw) = SPAWN_BLOCK, SPAWN_BOARD
        side = 1.0 if rng.integers(2) == 0 else -1.0
        block_xy = np.array([rng.uniform(*bxs), side * rng.uniform(*bys)])
        while True:
            board_xy = np.array([rng.uniform(*cxs), rng.uniform(*cys)])
            if np.linalg.norm(board_xy - block_xy) >= MIN_GAP:
                break
        block_pose = yaw_pose(*block_xy, TABLE_TOP_Z, np.deg2rad(rng.uniform(-byaw, byaw)))
        self.block.set_root_pose(block_pose)
        self.board.set_root_pose(yaw_pose(*board_xy, TABLE_TOP_Z, np.deg2rad(rng.uniform(-cyaw, cyaw))))
        # knife tip down in the slot, blade width along the slot, handle resting on the block's top
        down = sapien.Pose(q=[np.cos(np.pi / 4), 0, np.sin(np.pi / 4), 0])  # local x -> world -z
        centre = [0, 0, 2 * BLOCK_HALF[2] + HANDLE_L - KNIFE_HALF + 0.001]
        self.knife.set_pose(block_pose * sapien.Pose(centre) * down)
        body = self.knife.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
        body.set_linear_velocity([0, 0, 0])
        body.set_angular_velocity([0, 0, 0])
        self.variation = 0
        self.episode_instruction = self.instruction

    def on_board(self) -> bool:
        local = np.asarray((self.board.get_root_pose().inv() * self.knife.pose).p, dtype=float)
        over = abs(local[0]) < BOARD_HALF[0] and abs(local[1]) < BOARD_HALF[1]
        return bool(over and 0.0 < local[2] - 2 * BOARD_HALF[2] < 0.03)

    def evaluate(self) -> bool:
        # RLBench: an ordered ConditionSet (on the board, then nothing grasped)
        return self.ordered("placed", self.on_board, lambda: not self.grasped())

    def demonstration(self):
        knife = self.knife.pose
        rot = knife.to_transformation_matrix()[:3, :3]
        width = rot[:, 1]  # fingers close across the handle's width (along the slot)
        q = down_quat(half_turn(np.arctan2(width[1], width[0]) - np.pi / 2))
        butt = self.world_point(knife, [-KNIFE_HALF, 0, 0])
        grasp = butt - [0.0, 0.0, GRIP_FROM_BUTT]
        yield quantised(self.key(grasp + [0, 0, 0.06], q, True))
        yield quantised(self.key(grasp, q, False))
        # straight up until the tip is 2 cm above the block
        block_top = self.block.get_root_pose().p[2] + 2 * BLOCK_HALF[2]
        high = block_top + 0.02 + 2 * KNIFE_HALF - GRIP_FROM_BUTT
        yield quantised(self.key([grasp[0], grasp[1], high], q, False))
        # the knife hanging from the hand, over the board's near half, hand x along the board
        board = self.board.get_root_pose()
        along = board.to_transformation_matrix()[:3, 0]
        along = along if along[0] >= 0 else -along
        centre = np.asarray(board.p, dtype=float)
        over = centre - along * 0.06
        yield quantised(self.key([over[0], over[1], high], down_quat(np.arctan2(along[1], along[0])), False))
        # tip the knife forward until it points TILT below the horizontal, blade nearly flat
        up = np.array([0.0, 0.0, 1.0])
        z = np.cos(TILT) * along - np.sin(TILT) * up
        x = np.sin(TILT) * along + np.cos(TILT) * up
        tilted = quantised(self.key([over[0], over[1], high], frame_quat(x, np.cross(z, x), z), False))
        yield tilted
        # lower it until the tip is just above the board, the tip KNIFE_HALF beyond the board's
        # centre: let go and the knife falls flat, pivoting on its tip, centred on the board
        tcp = self.world.robot.tcp_pose()
        tip_in_hand = (tcp.inv() * self.knife.pose * sapien.Pose([KNIFE_HALF, 0, 0])).p
        tip = centre + along * KNIFE_HALF
        tip[2] = centre[2] + 2 * BOARD_HALF[2] + DROP
        place = tip - (sapien.Pose(q=tilted.quat_wxyz) * sapien.Pose(tip_in_hand)).p
        yield quantised(self.key(place, tilted.quat_wxyz, False))
        yield quantised(self.key(place, tilted.quat_wxyz, True))
        yield quantised(self.key(place + [0, 0, 0.08], tilted.quat_wxyz, True))
