"""put_rubbish_in_bin (unseen, level 1).

Task description:
    A crumpled ball of paper (the rubbish) and two tomatoes lie on the table in front of a
    round, open-topped waste bin. The robot picks up the rubbish from above, carries it over
    the bin and drops it in; the tomatoes are distractors and stay where they are.

Randomisations:
    - rubbish and tomato centres in x in [0.02, 0.22] m, y in [-0.26, 0.26] m, at least
      0.10 m apart, each with a random yaw;
    - bin centre x in [0.32, 0.42] m, y in [-0.18, 0.18] m, random yaw, at least 0.19 m from
      each of the other objects.
    - simulator.scenes: rlbench, as RLBench: one fixed layout (RLBench's own lives in its binary
      scene file, so the arrangement is ours: tomato 1, rubbish, tomato 2 in a row 12 cm apart,
      the bin 20 cm behind the rubbish), whose centre is drawn in x [0.14, 0.24] m, y [-0.10,
      0.10] m and which turns as a whole by [-180, 180] degrees; the rubbish stays in its spot
      or swaps places with one of the tomatoes (3 options, as RLBench's init_episode).

Success conditions:
    The rubbish is inside the bin (its centre within the bin's inner radius of the bin's axis
    and below its rim).
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, down_quat, half_turn, quantised, yaw_of

RUBBISH_HALF = (0.030, 0.026, 0.024)  # the crumpled paper's collision box
TOMATO_R = 0.03
BIN_R, BIN_H, BIN_WALL = 0.08, 0.13, 0.006  # outer radius, height, wall thickness
SEGMENTS = 16
GRIP_DEPTH = 0.012  # the TCP this far below the rubbish's top when holding it
SPAWN = ((0.02, 0.22), (-0.26, 0.26), 0.10)
SPAWN_BIN = ((0.32, 0.42), (-0.18, 0.18), 0.19)
#: simulator.scenes: rlbench: the fixed layout in its own frame (x away from the robot at yaw 0):
#: the home spots of rubbish, tomato 1, tomato 2, then the bin; and the box of its centre
LAYOUT_SPOTS = ((-0.07, 0.0), (-0.07, 0.12), (-0.07, -0.12))
LAYOUT_BIN = (0.13, 0.0)
LAYOUT_BOX = ((0.14, 0.24), (-0.10, 0.10))



class PutRubbishInBin(Task):
    name = "put_rubbish_in_bin"
    max_control_steps = 94  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "level1"
    instruction = "put rubbish in bin"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "put rubbish in bin",
        "drop the rubbish into the bin",
        "pick up the rubbish and leave it in the trash can",
        "throw away the trash, leaving any other objects alone",
        "chuck way any rubbish on the table rubbish",
    )
    object_names = ("rubbish", "tomato 1", "tomato 2", "bin")
    graspable_objects = ("rubbish",)  # RLBench registers only the rubbish

    def load(self) -> None:
        ab = self.world.scene.create_articulation_builder()
        body = ab.create_link_builder()
        body.set_name("bin")
        grey = look((0.22, 0.24, 0.26), roughness=0.5, metallic=0.3)
        add_cylinder(body, BIN_R - BIN_WALL, 0.003, sapien.Pose([0, 0, 0.003]), grey)  # floor
        mid = BIN_R - BIN_WALL / 2
        half_w = BIN_R * np.tan(np.pi / SEGMENTS)
        for k in range(SEGMENTS):
            phi = 2 * np.pi * k / SEGMENTS
            turn = [np.cos(phi / 2), 0, 0, np.sin(phi / 2)]
            pose = sapien.Pose([mid * np.cos(phi), mid * np.sin(phi), BIN_H / 2], turn)
            add_box(body, [BIN_WALL / 2, half_w, BIN_H / 2], pose, grey)
        self.bin = self.objects.articulation(ab, {"bin": "bin"}, "bin")

        # crumpled paper: a box collision under a heap of tilted off-white facets
        b = self.world.scene.create_actor_builder()
        b.add_box_collision(half_size=RUBBISH_HALF, material=physical(1.5), density=150.0)
        facets = np.random.default_rng(7)  # a fixed crumple, the same in every episode
        for _ in range(9):
            axis = facets.normal(size=3)
            axis /= np.linalg.norm(axis)
            angle = facets.uniform(0, np.pi)
            q = [np.cos(angle / 2), *(np.sin(angle / 2) * axis)]
            shade = facets.uniform(0.80, 0.95)
            b.add_box_visual(pose=sapien.Pose(facets.uniform(-0.006, 0.006, 3), q),
                             half_size=[v * facets.uniform(0.75, 0.95) for v in RUBBISH_HALF],
                             material=look((shade, shade, shade * 0.96), roughness=0.95))
        self.rubbish = self.objects.actor(b, "rubbish")

        self.tomatoes = []
        for i in range(2):
            t = self.world.scene.create_actor_builder()
            # flat-bottomed collision so a tomato does not roll away; a round look
            add_cylinder(t, TOMATO_R * 0.9, TOMATO_R * 0.85, None, (0.85, 0.12, 0.08), material=physical(1.0),
                         collide=True, density=900.0)
            t.add_sphere_visual(radius=TOMATO_R, material=look((0.85, 0.12, 0.08), roughness=0.3))
            t.add_box_visual(pose=sapien.Pose([0, 0, TOMATO_R]), half_size=[0.012, 0.003, 0.002],
                             material=look((0.15, 0.50, 0.12)))
            t.add_box_visual(pose=sapien.Pose([0, 0, TOMATO_R], [np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)]),
                             half_size=[0.012, 0.003, 0.002], material=look((0.15, 0.50, 0.12)))
            self.tomatoes.append(self.objects.actor(t, f"tomato {i + 1}"))

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        spots, yaws, bin_xy, bin_yaw = (self._rlbench_layout if self.rlbench_scenes else self._own_layout)(rng)
        self.bin.set_root_pose(yaw_pose(*bin_xy, TABLE_TOP_Z, bin_yaw))
        heights = [RUBBISH_HALF[2], TOMATO_R * 0.85, TOMATO_R * 0.85]
        for actor, spot, h, yaw in zip([self.rubbish, *self.tomatoes], spots, heights, yaws):
            actor.set_pose(yaw_pose(*spot, TABLE_TOP_Z + h + 0.001, yaw))
            body = actor.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
            body.set_linear_velocity([0, 0, 0])
            body.set_angular_velocity([0, 0, 0])
        self.variation = 0
        self.episode_instruction = self.instruction

    @staticmethod
    def _own_layout(rng: np.random.Generator):
        """Rubbish, tomatoes and bin each at their own random spot and yaw."""
        (xs, ys, gap), (bxs, bys, bgap) = SPAWN, SPAWN_BIN
        spots: list[np.ndarray] = []
        while len(spots) < 3:
            p = np.array([rng.uniform(*xs), rng.uniform(*ys)])
            if all(np.linalg.norm(p - q) >= gap for q in spots):
                spots.append(p)
        while True:
            bin_xy = np.array([rng.uniform(*bxs), rng.uniform(*bys)])
            if all(np.linalg.norm(bin_xy - q) >= bgap for q in spots):
                break
        bin_yaw = rng.uniform(-np.pi, np.pi)
        return spots, [rng.uniform(-np.pi, np.pi) for _ in spots], bin_xy, bin_yaw

    @staticmethod
    def _rlbench_layout(rng: np.random.Generator):
        """RLBench's way: the fixed layout placed and turned whole, the rubbish swapped with
        tomato 2 (0), left home (1) or swapped with tomato 1 (2)."""
        centre = np.array([rng.uniform(*LAYOUT_BOX[0]), rng.uniform(*LAYOUT_BOX[1])])
        yaw = rng.uniform(-np.pi, np.pi)
        turn = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
        home = [centre + turn @ np.asarray(spot) for spot in LAYOUT_SPOTS]
        order = {0: (2, 1, 0), 1: (0, 1, 2), 2: (1, 0, 2)}[int(rng.integers(3))]
        return [home[i] for i in order], [yaw] * 3, centre + turn @ np.asarray(LAYOUT_BIN), yaw

    def in_bin(self, actor: sapien.Entity) -> bool:
        p = np.asarray(actor.pose.p, dtype=float)
        base = np.asarray(self.bin.get_root_pose().p, dtype=float)
        off = np.linalg.norm(p[:2] - base[:2])
        return bool(off < BIN_R - BIN_WALL and p[2] < base[2] + BIN_H)

    def evaluate(self) -> bool:
        return self.in_bin(self.rubbish)

    def demonstration(self):
        centre = np.asarray(self.rubbish.pose.p, dtype=float)
        base = np.asarray(self.bin.get_root_pose().p, dtype=float)
        # fingers close across either side of the paper ball; the hand (long along its y axis)
        # is kept across the direction of the bin so that it does not hit the bin's rim
        to_bin = (base - centre)[:2] / np.linalg.norm((base - centre)[:2])
        yaw = yaw_of(self.rubbish.pose)
        theta = min((half_turn(yaw), half_turn(yaw + np.pi / 2)),
                    key=lambda t: abs(np.dot([np.sin(t), -np.cos(t)], to_bin)))
        q = down_quat(theta)
        grasp = centre + [0.0, 0.0, RUBBISH_HALF[2] - GRIP_DEPTH]
        yield quantised(self.key(grasp + [0, 0, 0.10], q, True))
        yield quantised(self.key(grasp, q, False))
        carry = base[2] + BIN_H + 0.03 + 2 * RUBBISH_HALF[2] - GRIP_DEPTH  # its bottom 3 cm above the rim
        # drop it 2.5 cm off the bin's axis on the robot's side: the far edge of the bin is a long reach
        near = np.asarray(self.world.robot.base_pose.p[:2]) - base[:2]
        drop = base[:2] + 0.025 * near / np.linalg.norm(near)
        yield quantised(self.key([grasp[0], grasp[1], carry], q, False))
        yield quantised(self.key([*drop, carry], q, False))
        yield quantised(self.key([*drop, carry], q, True))
        yield quantised(self.key([*drop, carry + 0.05], q, True))  # back off while it falls
