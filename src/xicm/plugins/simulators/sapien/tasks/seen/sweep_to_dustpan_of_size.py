"""sweep_to_dustpan_of_size (seen).

Task description:
    A broom (a long bristle head on an upright handle) stands on the table next to a small
    heap of five pieces of dirt; a tall dustpan lies on one side of the heap and a short one on
    the other, both open towards it. The robot takes the broom by the top of its handle, sets
    the head down behind the heap and sweeps the dirt into the named dustpan.

Randomisations:
    - the dustpan to sweep into (variation 0: tall; tall or short when variations are
      sampled) and which side (left or right) each dustpan lies on;
    - dirt heap centre x in [0.16, 0.22] m, y in [-0.03, 0.03] m, pieces spread +- 2.5 cm;
    - dustpan centres x within 2 cm of the heap's, |y| in [0.23, 0.26] m;
    - broom centre x in [-0.02, 0.03] m, y in [-0.06, 0.06] m, yaw in [-180, 180] degrees
      (RLBench's default; was [-20, 20]);
    - simulator.scenes: rlbench also turns the whole layout (dustpans, dirt and broom together)
      by a yaw in [-180, 180] degrees about (0.10, 0) m, as RLBench turns the task's base (its
      default bounds); draws the demonstrator fails are redrawn.

Success conditions:
    All five pieces of dirt lie on the named dustpan's floor (between its walls).
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, down_quat, snap_to_grid, yaw_of

SIZES = ("tall", "short")
WALL_H = {"tall": 0.08, "short": 0.03}
PAN_HALF = (0.11, 0.065)  # floor half sizes: x (across the opening), y (depth)
PAN_WALL = 0.006
HEAD_HALF = (0.075, 0.015, 0.0125)  # broom head: length (along x), thickness, height
HANDLE_HALF = (0.008, 0.008, 0.07)
DIRT_HALF = 0.007
N_DIRT = 5
STEP = np.deg2rad(5.0)
LAYOUT_CENTRE = (0.10, 0.0)  # between broom and heap: the layout turns about it


def near(angle: float, ref: float, period: float) -> float:
    """angle + k * period closest to ref."""
    return float(angle + np.round((ref - angle) / period) * period)


class SweepToDustpanOfSize(Task):
    name = "sweep_to_dustpan_of_size"
    max_control_steps = 86  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "seen"
    instruction = "sweep dirt to the tall dustpan"
    phrasings = (  # RLBench's variation-0 phrasings, AGNOSTOS's instruction first
        "sweep dirt to the tall dustpan",
        "sweep the dirt up into the tall dustpan",
        "use the broom to brush the dirt into the tall dustpan",
        "clean up the dirt with the tall pan",
    )
    object_names = ("broom", "dirt", "tall dustpan", "short dustpan")
    graspable_objects = ("broom",)  # only the tool is held (what it moves is not)

    def _build_dustpan(self, size: str) -> sapien.Entity:
        """A dustpan in its own frame: floor centred at the origin, opening towards -y."""
        b = self.world.scene.create_actor_builder()
        colour = (0.15, 0.45, 0.75) if size == "tall" else (0.85, 0.45, 0.15)
        hx, hy, h = PAN_HALF[0], PAN_HALF[1], WALL_H[size]
        # floor flush with the table top (thin visual layer on a sunk collision box)
        b.add_box_collision(sapien.Pose([0, 0, -0.0052]), half_size=[hx, hy, 0.005])
        add_box(b, [hx, hy, 0.0005], sapien.Pose([0, 0, 0.0005]), colour, collide=False)
        add_box(b, [hx + PAN_WALL, PAN_WALL / 2, h / 2], sapien.Pose([0, hy + PAN_WALL / 2, h / 2]), colour)
        for s in (-1, 1):
            add_box(b, [PAN_WALL / 2, hy, h / 2], sapien.Pose([s * (hx + PAN_WALL / 2), 0, h / 2]), colour)
        return self.objects.actor(b, f"{size} dustpan", kind="static")

    def load(self) -> None:
        scene = self.world.scene
        self.pans = [self._build_dustpan(s) for s in SIZES]
        b = scene.create_actor_builder()
        add_box(
            b, HEAD_HALF, sapien.Pose([0, 0, HEAD_HALF[2]]), (0.35, 0.22, 0.1), material=physical(0.3), density=600.0
        )
        handle = sapien.Pose([0, 0, 2 * HEAD_HALF[2] + HANDLE_HALF[2]])
        add_box(b, HANDLE_HALF, handle, (0.75, 0.6, 0.35), material=physical(1.5), density=300.0)
        self.broom = self.objects.actor(b, "broom")
        self.dirt = []
        for _ in range(N_DIRT):
            b = scene.create_actor_builder()
            add_box(b, [DIRT_HALF] * 3, color=(0.25, 0.18, 0.1), material=physical(0.4), density=600.0)
            self.dirt.append(self.objects.actor(b, "dirt"))

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        variation = int(rng.integers(len(SIZES)))
        self.variation = variation if sample_variation else 0
        self.episode_instruction = f"sweep dirt to the {SIZES[self.variation]} dustpan"
        sides = (1.0, -1.0) if rng.random() < 0.5 else (-1.0, 1.0)
        self.sides = sides
        cx, cy = rng.uniform(0.16, 0.22), rng.uniform(-0.03, 0.03)
        for pan, side in zip(self.pans, sides):
            # opening (local -y) towards the heap
            yaw = 0.0 if side > 0 else np.pi
            pan.set_pose(yaw_pose(cx + rng.uniform(-0.02, 0.02), side * rng.uniform(0.23, 0.26), TABLE_TOP_Z, yaw))
        placed: list[np.ndarray] = []
        while len(placed) < N_DIRT:
            p = np.array([cx, cy]) + rng.uniform(-0.025, 0.025, 2)
            if all(np.linalg.norm(p - q) > 2.5 * DIRT_HALF for q in placed):
                placed.append(p)
        for piece, p in zip(self.dirt, placed):
            piece.set_pose(yaw_pose(p[0], p[1], TABLE_TOP_Z + DIRT_HALF, rng.uniform(-np.pi / 4, np.pi / 4)))
        bx, by = rng.uniform(-0.02, 0.03), rng.uniform(-0.06, 0.06)
        self.broom.set_pose(yaw_pose(bx, by, TABLE_TOP_Z + 0.0005, np.deg2rad(rng.uniform(-180.0, 180.0))))
        self.layout_yaw = self.turn_base(rng, [*self.pans, *self.dirt, self.broom], LAYOUT_CENTRE)

    def dirt_in(self, index: int) -> bool:
        pan = self.pans[index].pose.inv()
        for piece in self.dirt:
            local = np.asarray((pan * piece.pose).p)
            if not (abs(local[0]) < PAN_HALF[0] and abs(local[1]) < PAN_HALF[1] and local[2] < 0.03):
                return False
        return True

    def evaluate(self) -> bool:
        return self.dirt_in(self.variation)

    def demonstration(self):
        broom = self.broom.pose
        top = self.world_point(broom, [0, 0, 2 * HEAD_HALF[2] + 2 * HANDLE_HALF[2] - 0.015])
        theta_g = float(np.round(yaw_of(broom) / STEP) * STEP)  # hand x along the head
        grasp = snap_to_grid(top)
        yield self.key(grasp + [0, 0, 0.08], down_quat(theta_g), True)
        yield self.key(grasp, down_quat(theta_g), False)
        held = self.world.robot.tcp_pose().inv() * self.broom.pose  # the broom in the hand
        yield self.key(snap_to_grid(grasp + [0, 0, 0.05]), down_quat(theta_g), False)

        # the layout's own axes (world x and y unless simulator.scenes: rlbench turned it):
        # the head lies along `across`, the sweep runs along `ahead`, towards the named dustpan
        c, s = np.cos(self.layout_yaw), np.sin(self.layout_yaw)
        across = np.array([c, s])
        ahead = self.sides[self.variation] * np.array([-s, c])
        pan = np.asarray(self.pans[self.variation].pose.p)[:2] @ ahead
        dirt = np.array([np.asarray(d.pose.p)[:2] for d in self.dirt])
        # head along `across`: the hand yaw that turns the broom's head onto it
        # hand-frame z points down, so the broom's world yaw is the hand yaw minus its in-hand yaw;
        # the head is symmetric: of the two hand yaws take the one nearer the grasp yaw
        theta = float(np.round(near(yaw_of(held) + self.layout_yaw, theta_g, np.pi) / STEP) * STEP)
        q = down_quat(theta)
        rot = sapien.Pose(q=q).to_transformation_matrix()[:3, :3]
        offset = rot @ np.asarray(held.p)  # TCP -> broom origin (bottom centre of the head)
        x = float(np.mean(dirt @ across))
        behind = np.min(dirt @ ahead) - (HEAD_HALF[1] + DIRT_HALF + 0.025)
        opening = pan - PAN_HALF[1]
        end = opening + (0.03 - HEAD_HALF[1])  # head's front face 3 cm into the dustpan
        low = TABLE_TOP_Z + 0.003 - offset[2]  # head 3 mm above the table (-2 to 8 mm on the grid)
        start = snap_to_grid([*(x * across + behind * ahead - offset[:2]), low])
        stop = snap_to_grid([*(x * across + end * ahead - offset[:2]), low])
        yield self.key(snap_to_grid([start[0], start[1], low + 0.05]), q, False)
        yield self.key(start, q, False)
        yield self.key(stop, q, False)
        yield self.key(snap_to_grid([stop[0], stop[1], low + 0.06]), q, False)
