"""place_cups (seen).

Task description:
    Three mugs with handles (red, green, blue) stand on the table in front of a cup holder: a
    mug tree whose upright pole carries three slightly upturned spokes, pointing left, right
    and towards the robot. The robot picks mugs up by their bodies and hangs them by their
    handles on the spokes, one mug per spoke, until the asked number of mugs hang there.

Randomisations:
    - how many mugs to hang (variation 0: 1; 1, 2 or 3 when variations are sampled);
    - cup holder centre x in [0.30, 0.34] m, y in [-0.04, 0.04] m, not turned (RLBench turns it
      by [-90, 90] degrees; a spoke turned away from the robot is mostly out of reach, so
      simulator.scenes: rlbench draws that and redraws scenes the demonstrator fails);
    - mug centres x in [0.00, 0.14] m, y in [-0.25, 0.25] m, at least 0.14 m apart, each with
      its handle pointing anywhere (yaw in [-180, 180] degrees).

Success conditions:
    At least the asked number of mugs hang on spokes (the spoke runs through the mug's
    handle and the mug is off the table) AND nothing is grasped.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, down_quat, snap_to_grid, yaw_of

COLOURS = ("red", "green", "blue")
MUG_R, MUG_H = 0.026, 0.08
HANDLE_OUT = 0.032  # handle reaches this far out of the body
ARM_T = 0.003  # handle half thickness (arms and bar)
HANDLE_W = 0.006  # handle half width
ARM_Z = (0.012, 0.050)  # heights of the handle's lower and upper arm
LOOP = np.array([MUG_R + (HANDLE_OUT - 2 * ARM_T) / 2, 0.0, sum(ARM_Z) / 2])  # opening centre (mug frame)
POLE_R, POLE_H = 0.01, 0.28
SPOKE_R, SPOKE_L = 0.005, 0.11
SPOKE_TILT = np.deg2rad(15.0)
#: spokes: (direction yaw, height above the table, yaw of the handle of a mug hung on it)
SPOKES = ((np.pi / 2, 0.13, np.pi), (np.pi, 0.17, -np.pi / 2), (-np.pi / 2, 0.21, 0.0))
GRIP_DOWN = 0.012  # TCP this far below the mug's rim
STEP = np.deg2rad(5.0)


def wrist(theta: float) -> float:
    """theta wrapped into [-135, 225) degrees, around the Panda's mid-range hand yaw of 45."""
    c = np.pi / 4
    return float((theta - c + np.pi) % (2 * np.pi) - np.pi + c)


class PlaceCups(Task):
    name = "place_cups"
    max_control_steps = 418  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "seen"
    instruction = "place 1 cup on the cup holder"
    phrasings = (  # RLBench's variation-0 phrasings, AGNOSTOS's instruction first
        "place 1 cup on the cup holder",
        "pick up one cup and put it on the mug tree",
        "move 1 mug from the table to the cup holder",
        "pick up one cup and slide its handle onto a spoke on the mug holder",
    )
    object_names = ("red cup", "green cup", "blue cup", "cup holder")

    def _build_mug(self, colour: str) -> sapien.Entity:
        b = self.world.scene.create_actor_builder()
        mat = physical(1.0)
        add_cylinder(b, MUG_R, MUG_H / 2, sapien.Pose([0, 0, MUG_H / 2]), colour, material=mat, density=400.0)
        add_cylinder(b, MUG_R - 0.004, 0.0006, sapien.Pose([0, 0, MUG_H]), (0.12, 0.08, 0.05), collide=False)
        for z in ARM_Z:
            add_box(
                b,
                [HANDLE_OUT / 2 + 0.002, HANDLE_W, ARM_T],
                sapien.Pose([MUG_R + HANDLE_OUT / 2 - 0.002, 0, z]),
                colour,
                material=mat,
            )
        bar = sapien.Pose([MUG_R + HANDLE_OUT - ARM_T, 0, sum(ARM_Z) / 2])
        add_box(b, [ARM_T, HANDLE_W, (ARM_Z[1] - ARM_Z[0]) / 2 + ARM_T], bar, colour, material=mat)
        return self.objects.actor(b, f"{colour} cup")

    def spoke_pose(self, k: int) -> sapien.Pose:
        """Spoke k's frame: origin on the pole axis at the spoke's height, x along the spoke."""
        yaw, height, _ = SPOKES[k]
        tree = np.asarray(self.tree.pose.p)
        turn = yaw_pose(tree[0], tree[1], tree[2] + height, yaw + yaw_of(self.tree.pose))
        return turn * sapien.Pose(q=[np.cos(-SPOKE_TILT / 2), 0, np.sin(-SPOKE_TILT / 2), 0])

    def _build_tree(self) -> sapien.Entity:
        b = self.world.scene.create_actor_builder()
        wood = (0.55, 0.38, 0.22)
        add_cylinder(b, 0.05, 0.006, sapien.Pose([0, 0, 0.006]), wood)
        add_cylinder(b, POLE_R, POLE_H / 2, sapien.Pose([0, 0, POLE_H / 2]), wood)
        for yaw, height, _ in SPOKES:
            frame = yaw_pose(0, 0, height, yaw) * sapien.Pose(
                q=[np.cos(-SPOKE_TILT / 2), 0, np.sin(-SPOKE_TILT / 2), 0]
            )
            add_cylinder(
                b,
                SPOKE_R,
                SPOKE_L / 2,
                frame * sapien.Pose([SPOKE_L / 2, 0, 0]),
                wood,
                material=physical(0.8),
                axis="x",
            )
        return self.objects.actor(b, "cup holder", kind="static")

    def load(self) -> None:
        self.tree = self._build_tree()
        self.mugs = [self._build_mug(c) for c in COLOURS]

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        variation = int(rng.integers(3))
        self.variation = variation if sample_variation else 0
        self.count = self.variation + 1
        self.episode_instruction = f"place {self.count} cup{'s' if self.count > 1 else ''} on the cup holder"
        self.tree.set_pose(sapien.Pose([rng.uniform(0.30, 0.34), rng.uniform(-0.04, 0.04), TABLE_TOP_Z]))
        positions: list[np.ndarray] = []
        while len(positions) < len(self.mugs):
            p = np.array([rng.uniform(0.0, 0.14), rng.uniform(-0.25, 0.25)])
            if all(np.linalg.norm(p - q) >= 0.14 for q in positions):
                positions.append(p)
        for mug, p in zip(self.mugs, positions):
            mug.set_pose(yaw_pose(p[0], p[1], TABLE_TOP_Z + 0.0005, rng.uniform(-np.pi, np.pi)))
        # drawn last, so that `ours` (no turn) keeps the scenes it always had
        tree_yaw = np.deg2rad(rng.uniform(*self.span(ours=(0.0, 0.0), rlbench=(-90.0, 90.0))))
        tree = np.asarray(self.tree.pose.p)
        self.tree.set_pose(yaw_pose(tree[0], tree[1], TABLE_TOP_Z, tree_yaw))

    def hanging(self, mug: int) -> bool:
        """Whether a spoke runs through the mug's handle and the mug is off the table."""
        pose = self.mugs[mug].pose
        if np.asarray((pose * sapien.Pose([0, 0, MUG_H / 2])).p)[2] < TABLE_TOP_Z + 0.06:
            return False
        loop = pose * sapien.Pose(LOOP)
        for k in range(len(SPOKES)):
            local = np.asarray((self.spoke_pose(k).inv() * loop).p)
            if 0.01 < local[0] < SPOKE_L and np.hypot(local[1], local[2]) < 0.022:
                return True
        return False

    def evaluate(self) -> bool:
        if sum(self.hanging(i) for i in range(len(self.mugs))) < self.count:
            return False
        return not (self.grasped() & {m.per_scene_id for m in self.mugs})

    def demonstration(self):
        tree_yaw = yaw_of(self.tree.pose)
        by_y = sorted(range(len(self.mugs)), key=lambda i: -float(self.mugs[i].pose.p[1]))
        # the spoke that faces the robot most takes the middle mug, the others the mugs on their side
        # (the tree unturned: towards the robot, left, right)
        facing = max(range(len(SPOKES)), key=lambda k: -np.cos(SPOKES[k][0] + tree_yaw))
        others = (k for k in range(len(SPOKES)) if k != facing)
        left, right = sorted(others, key=lambda k: -np.sin(SPOKES[k][0] + tree_yaw))
        plan = [(by_y[1], facing), (by_y[0], left), (by_y[2], right)]  # (mug, spoke): middle mug first
        for n, (mug_index, k) in enumerate(plan[: self.count]):
            mug = self.mugs[mug_index]
            psi0 = yaw_of(mug.pose)
            psi_hang = SPOKES[k][2] + tree_yaw
            # hand x along the handle (fingers clear of it); of the two ways, the wrist-friendlier
            a = min(
                (0.0, np.pi), key=lambda a: max(abs(wrist(psi0 + a) - np.pi / 4), abs(wrist(psi_hang + a) - np.pi / 4))
            )
            theta_g = float(np.round(wrist(psi0 + a) / STEP) * STEP)
            top = np.asarray(mug.pose.p) + [0, 0, MUG_H - GRIP_DOWN]
            grasp = snap_to_grid(top)
            yield self.key(grasp + [0, 0, 0.10], down_quat(theta_g), True)
            yield self.key(grasp, down_quat(theta_g), False)
            held = self.world.robot.tcp_pose().inv() * mug.pose  # the mug in the hand
            high = TABLE_TOP_Z + POLE_H + 0.06 + MUG_H - GRIP_DOWN
            yield self.key(snap_to_grid([grasp[0], grasp[1], high]), down_quat(theta_g), False)

            # hand yaw that turns the handle to psi_hang (world yaw = hand yaw - in-hand yaw)
            theta = float(np.round(wrist(psi_hang + yaw_of(held)) / STEP) * STEP)
            q = down_quat(theta)
            tcp_to_loop = np.asarray((sapien.Pose(q=q) * held * sapien.Pose(LOOP)).p)
            spoke = self.spoke_pose(k)
            axis = spoke.to_transformation_matrix()[:3, 0]
            base = np.asarray(spoke.p)
            outside = snap_to_grid(base + axis * (SPOKE_L + 0.035) - tcp_to_loop)
            threaded = snap_to_grid(base + axis * 0.05 - tcp_to_loop)
            hung = snap_to_grid(threaded - [0, 0, 0.012])
            yield self.key([outside[0], outside[1], high], q, False)
            yield self.key(outside, q, False)
            yield self.key(threaded, q, False)
            yield self.key(hung, q, True)
            if n < self.count - 1:  # clear of the tree before the next mug; after the last, stay
                yield self.key(snap_to_grid(hung + [0, 0, 0.10]), q, True)
