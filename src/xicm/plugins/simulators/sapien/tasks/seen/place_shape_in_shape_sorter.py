"""place_shape_in_shape_sorter (seen).

Task description:
    A shape sorter (a hollow box whose lid has a cube-, cylinder-, cross- and cuboid-shaped
    slot) stands on the table behind four shapes: a cube, a cylinder, a cross and a cuboid.
    The robot picks up the named shape, turns it to match its slot, and drops it through the
    slot into the sorter.

Randomisations:
    - the shape to sort (variation 0: cube; any of the four when variations are sampled);
    - sorter centre x in [0.30, 0.34] m, y in [-0.05, 0.05] m, yaw in [-45, 45] degrees (RLBench's
      default is [-180, 180]; there the demonstrator fails 6 of 100 seeds, the cylinder and the
      cuboid jamming in their slots with the sorter turned by 60 to 120 degrees);
    - shape centres x in [0.00, 0.14] m, y in [-0.24, 0.24] m, at least 0.09 m apart,
      yaw in [-45, 45] degrees (for sorter and shapes, simulator.scenes: rlbench draws
      [-180, 180] and redraws scenes the demonstrator fails).

Success conditions:
    The named shape is inside the sorter: its centre within the sorter's walls and below its lid.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, down_quat, snap_to_grid, yaw_of

SHAPES = ("cube", "cylinder", "cross", "cuboid")
COLOURS = {"cube": "red", "cylinder": "green", "cross": "blue", "cuboid": "yellow"}
SYMMETRY = {"cube": np.pi / 2, "cylinder": np.pi / 2, "cross": np.pi / 2, "cuboid": np.pi}
SHAPE_H = 0.04  # all shapes are 4 cm tall
CUBE, CYL_R, CROSS_L, CROSS_W, CUBOID = 0.036, 0.018, 0.05, 0.018, (0.06, 0.024)
CLEAR = 0.009  # slot clearance on each side
SORTER_HALF = (0.065, 0.16)  # x (depth), y (width)
SORTER_H = 0.10  # lid top above the table
LID = 0.01
WALL = 0.008
SLOT_Y = {"cube": -0.11, "cylinder": -0.037, "cross": 0.037, "cuboid": 0.11}
CELL = 0.003  # raster of the lid's slots
GRID = 0.01  # text-grid cell size
STEP = np.deg2rad(5.0)  # text-grid rotation bin


def near(angle: float, ref: float, period: float) -> float:
    """angle + k * period closest to ref."""
    return float(angle + np.round((ref - angle) / period) * period)


def in_slot(shape: str, x: float, y: float) -> bool:
    """Whether the lid point (x, y), relative to the slot centre, is open."""
    if shape == "cube":
        return abs(x) < CUBE / 2 + CLEAR and abs(y) < CUBE / 2 + CLEAR
    if shape == "cylinder":
        return np.hypot(x, y) < CYL_R + CLEAR
    if shape == "cross":
        long, short = CROSS_L / 2 + CLEAR, CROSS_W / 2 + CLEAR
        return (abs(x) < long and abs(y) < short) or (abs(x) < short and abs(y) < long)
    return abs(x) < CUBOID[0] / 2 + CLEAR and abs(y) < CUBOID[1] / 2 + CLEAR


class PlaceShapeInShapeSorter(Task):
    name = "place_shape_in_shape_sorter"
    max_control_steps = 106  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "seen"
    instruction = "put the cube in the shape sorter"
    phrasings = (  # RLBench's variation-0 phrasings, AGNOSTOS's instruction first
        "put the cube in the shape sorter",
        "pick up the cube and put it in the sorter",
        "place the cube into its slot in the shape sorter",
        "slot the cube into the shape sorter",
    )
    object_names = ("shape sorter", "cube", "cylinder", "cross", "cuboid")

    def _build_sorter(self) -> sapien.Entity:
        b = self.world.scene.create_actor_builder()
        colour = (0.55, 0.35, 0.65)
        hx, hy = SORTER_HALF
        wall_h = (SORTER_H - LID) / 2
        for s in (-1, 1):
            add_box(b, [WALL / 2, hy, wall_h], sapien.Pose([s * (hx - WALL / 2), 0, wall_h]), colour)
            add_box(b, [hx, WALL / 2, wall_h], sapien.Pose([0, s * (hy - WALL / 2), wall_h]), colour)
        # the lid, rasterised row by row around the slots
        z = SORTER_H - LID / 2
        xs = np.arange(-hx + CELL / 2, hx, CELL)
        ys = np.arange(-hy + CELL / 2, hy, CELL)
        for x in xs:
            solid = [not any(in_slot(s, x, y - SLOT_Y[s]) for s in SHAPES) for y in ys]
            start = None
            for k, filled in enumerate([*solid, False]):
                if filled and start is None:
                    start = k
                elif not filled and start is not None:
                    y0, y1 = ys[start] - CELL / 2, ys[k - 1] + CELL / 2
                    add_box(b, [CELL / 2, (y1 - y0) / 2, LID / 2], sapien.Pose([x, (y0 + y1) / 2, z]), colour)
                    start = None
        return self.objects.actor(b, "shape sorter", kind="static")

    def _build_shape(self, shape: str) -> sapien.Entity:
        b = self.world.scene.create_actor_builder()
        mat, colour, h = physical(1.0), COLOURS[shape], SHAPE_H / 2
        if shape == "cube":
            add_box(b, [CUBE / 2, CUBE / 2, h], color=colour, material=mat)
        elif shape == "cylinder":
            add_cylinder(b, CYL_R, h, color=colour, material=mat)
        elif shape == "cross":
            add_box(b, [CROSS_L / 2, CROSS_W / 2, h], color=colour, material=mat)
            add_box(b, [CROSS_W / 2, CROSS_L / 2, h], color=colour, material=mat)
        else:
            add_box(b, [CUBOID[0] / 2, CUBOID[1] / 2, h], color=colour, material=mat)
        return self.objects.actor(b, shape)

    def load(self) -> None:
        self.sorter = self._build_sorter()
        self.shapes = [self._build_shape(s) for s in SHAPES]

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        variation = int(rng.integers(len(SHAPES)))
        self.variation = variation if sample_variation else 0
        self.episode_instruction = f"put the {SHAPES[self.variation]} in the shape sorter"
        yaw = np.deg2rad(rng.uniform(*self.span(ours=(-45.0, 45.0), rlbench=(-180.0, 180.0))))
        self.sorter.set_pose(yaw_pose(rng.uniform(0.30, 0.34), rng.uniform(-0.05, 0.05), TABLE_TOP_Z, yaw))
        positions: list[np.ndarray] = []
        while len(positions) < len(self.shapes):
            p = np.array([rng.uniform(0.0, 0.14), rng.uniform(-0.24, 0.24)])
            if all(np.linalg.norm(p - q) >= 0.09 for q in positions):
                positions.append(p)
        for shape, p in zip(self.shapes, positions):
            shape_yaw = np.deg2rad(rng.uniform(*self.span(ours=(-45.0, 45.0), rlbench=(-180.0, 180.0))))
            shape.set_pose(yaw_pose(p[0], p[1], TABLE_TOP_Z + SHAPE_H / 2, shape_yaw))

    def in_sorter(self, index: int) -> bool:
        local = np.asarray((self.sorter.pose.inv() * self.shapes[index].pose).p)
        inside = abs(local[0]) < SORTER_HALF[0] - WALL and abs(local[1]) < SORTER_HALF[1] - WALL
        return bool(inside and local[2] < SORTER_H - LID - 0.01)

    def evaluate(self) -> bool:
        return self.in_sorter(self.variation)

    def demonstration(self):
        shape = SHAPES[self.variation]
        body = self.shapes[self.variation]
        period = SYMMETRY[shape]
        theta_g = near(yaw_of(body.pose), 0.0, period)  # hand x along a shape axis; fingers across it
        theta_g = float(np.round(theta_g / STEP) * STEP)
        q_g = down_quat(theta_g)
        grasp = snap_to_grid([body.pose.p[0], body.pose.p[1], TABLE_TOP_Z + SHAPE_H - 0.015])
        yield self.key(grasp + [0, 0, 0.10], q_g, True)
        yield self.key(grasp, q_g, False)
        yield self.key(snap_to_grid(grasp + [0, 0, SORTER_H + 0.08]), q_g, False)

        held = self.world.robot.tcp_pose().inv() * body.pose  # the shape in the hand
        slot_pose = self.sorter.pose * sapien.Pose([0, SLOT_Y[shape], 0])
        # hand yaw that lines the shape up with its slot, closest to the grasp yaw
        # (hand-frame z points down: the shape's world yaw is the hand yaw minus its in-hand yaw)
        theta_r = near(yaw_of(slot_pose) + yaw_of(held), theta_g, period)
        theta_r = float(np.round(theta_r / STEP) * STEP)
        q_r = down_quat(theta_r)
        rot = sapien.Pose(q=q_r).to_transformation_matrix()[:3, :3]
        offset = rot @ np.asarray(held.p)  # TCP -> shape centre
        slot = np.asarray(slot_pose.p)
        # let go with the shape's bottom 6 mm (1 to 11 mm on the grid) down in its slot, so it
        # cannot turn away from the slot as the fingers open; the fingertips stay above the lid
        drop_z = TABLE_TOP_Z + SORTER_H - 0.006 + SHAPE_H / 2
        release = snap_to_grid([slot[0] - offset[0], slot[1] - offset[1], drop_z - offset[2]])
        yield self.key(snap_to_grid([release[0], release[1], grasp[2] + SORTER_H + 0.08]), q_r, False)
        yield self.key(release, q_r, True)
        yield self.key(release + [0, 0, 0.08], q_r, True)
