"""straighten_rope (unseen, level 2).

Task description:
    A rope lies on the table in a loose curve: nine grey links with a red block at its head and
    a blue block at its tail. Two flat target zones are marked on the table, a red one for the
    head and a blue one for the tail, 28 cm apart (the rope is 32 cm long between the centres
    of its end blocks). The robot takes the head to its zone, then takes the tail and pulls it
    out to its zone, which straightens the rope.

    The rope is one free articulation: head block (root), nine capsule links, tail block. Each
    joint is a yaw hinge (+-75 degrees) and a pitch hinge (+-60 degrees) through a massless link;
    at the end blocks a twist hinge (about the rope) follows, so a block lies flat whatever twist
    the chain has. The rope's parts do not collide with each other, the joints carry a little
    damping (a zero-stiffness drive; no spring), and the rope never sleeps (a sleeping PhysX
    articulation woken by the gripper jumped). The end blocks are heavy (~0.18 kg) and grippy
    (friction 1.5), the links light (~2 g) and slippery (0.2), so an end that was put down stays
    put while the other end is moved and the rope slides after it.

    Demonstrator: grasp the head across its width, lift it 2 cm, carry it to its zone while
    turning it to face the tail zone, put it down and let go. Then grasp the tail, lift it 2 cm
    and pull it radially out to the zones' distance from the head, swing it round the head at
    that radius in steps of at most 30 degrees (turning it to point away from the head) to the
    tail zone, put it down and let go. The rope is never pulled taut (zones 28 cm apart, rope
    32 cm), so the placed head is not dragged. 12-13 key actions.

Randomisations:
    - the rope's shape: a C-curve (total bend 110-170 degrees) or an S-curve (the halves bent
      120-170 degrees each, opposite ways), with +-4 degrees of noise per joint, lying flat
      (head to tail 18-29 cm, median 23 cm);
    - the rope's chord (head to tail) midpoint x in [0.17, 0.27] m, y in [-0.10, 0.10] m, its
      direction any yaw;
    - the zones' axis: the chord direction +-30 degrees, their midpoint within +-4 cm (x and y)
      of the chord midpoint; all resampled until both ends start outside their zones (by more
      than 1 cm) and the zone centres and the rope's ends lie in x [0.02, 0.42] m, |y| <= 0.3 m.
    - simulator.scenes: rlbench, as RLBench (whose rope and zones are fixed by its scene file and
      only the base is placed): one rope shape, an S-curve with halves bent 145 degrees, no
      noise, and the zones' axis 20 degrees off the chord through its midpoint (both ours: the
      scene file is not readable here); the chord midpoint and yaw are drawn as above, so rope
      and zones move and turn together.

Success conditions:
    The head block's centre is within 3 cm (horizontally) of the head zone's centre AND the tail
    block's centre within 3 cm of the tail zone's centre, both resting on the table (centre less
    than 3 cm above it; a block held 2 cm up does not count). Ends 28 +- 6 cm apart leave the
    32 cm rope nearly straight. Nothing needs to be let go of (as upstream: zone sensors only).
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, down_quat, quantised, snap_to_grid, yaw_of

N_LINKS = 9
SPACING = 0.03  # joint to joint along a link
LINK_R = 0.007
END_HALF = (0.025, 0.015, 0.02)  # end blocks: along the rope, across (the grasp width), height
ANCHOR_DZ = LINK_R - END_HALF[2]  # the rope leaves the end blocks at link height
ZONE_D = 0.28  # distance between the zone centres
ZONE_R = 0.03
LIFT = 0.02
SWING = np.deg2rad(30.0)
#: simulator.scenes: rlbench: the one rope shape (S-curve, each half bent this much) and the zones'
#: axis against the chord (ends then start 5 cm from their zones)
RLBENCH_BEND = np.deg2rad(145.0)
RLBENCH_ZONE_TURN = np.deg2rad(20.0)
STEP = np.deg2rad(5.0)
ROPE_GROUP = 1 << 20  # shared collision-group bit: the rope's parts do not collide with each other
YAW_AXIS = [np.cos(np.pi / 4), 0.0, -np.sin(np.pi / 4), 0.0]  # joint x axis -> local z
PITCH_AXIS = [np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)]  # joint x axis -> local y
BEND_LIMIT = np.deg2rad(75.0)
PITCH_LIMIT = np.deg2rad(60.0)
TWIST_LIMIT = np.deg2rad(170.0)
JOINT_DAMPING = 2e-4
HINGE_MASS, HINGE_INERTIA = 1e-3, 1e-7  # the massless link between a yaw and a pitch hinge
END_DENSITY, END_FRICTION = 3000.0, 1.5
LINK_DENSITY, LINK_FRICTION = 300.0, 0.2


def wrap(a: float) -> float:
    return float((a + np.pi) % (2 * np.pi) - np.pi)


def on_grid(a: float) -> float:
    return float(np.round(a / STEP) * STEP)


def hand_yaws(block_yaw: float, turns: list[float]) -> list[float]:
    """Hand yaws that hold a block (hand x along it) while it turns by each of `turns` in order.

    The gripper is symmetric, so the block can be taken at its yaw or that +180 degrees: take the
    one that keeps the hand nearest to yaw 0 all the way (the Panda wrist's comfortable middle).
    """
    best = None
    for start in (wrap(block_yaw), wrap(block_yaw + np.pi)):
        yaws = [on_grid(start + t) for t in turns]
        worst = max(abs(y) for y in yaws)
        if best is None or worst < best[0]:
            best = (worst, yaws)
    return best[1]


class StraightenRope(Task):
    name = "straighten_rope"
    max_control_steps = 188  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "level2"
    instruction = "straighten rope"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "straighten rope",
        "pull the rope straight",
        "grasping each end of the rope in turn, leave the rope straight on the table",
        "pull each end of the rope until is is straight",
        "tighten the rope",
        "pull the rope tight",
    )
    object_names = ("rope", "rope head", "rope tail", "head target", "tail target")

    def load(self) -> None:
        scene = self.world.scene
        ab = scene.create_articulation_builder()
        grey = look((0.55, 0.55, 0.5), roughness=0.9)
        tiny = {"mass": HINGE_MASS, "cmass_local_pose": sapien.Pose(), "inertia": [HINGE_INERTIA] * 3}

        def end_block(parent, colour, name):
            lb = ab.create_link_builder(parent)
            lb.set_name(name)
            lb.collision_groups = [1, 1, ROPE_GROUP, 0]
            add_box(lb, END_HALF, color=colour, material=physical(END_FRICTION), density=END_DENSITY)
            return lb

        head = end_block(None, "red", "head")
        parts, anchor = [head], [END_HALF[0], 0, ANCHOR_DZ]
        for k in range(N_LINKS + 1):
            # yaw and pitch hinges through massless joint links; at the end blocks also a twist
            # hinge (about the rope), so a block can lie flat whatever twist the chain has
            hinges = [("bend", YAW_AXIS, BEND_LIMIT), ("pitch", PITCH_AXIS, PITCH_LIMIT)]
            if k in (0, N_LINKS):
                hinges.append(("twist", [1.0, 0.0, 0.0, 0.0], TWIST_LIMIT))
            child = [-SPACING / 2, 0, 0] if k < N_LINKS else [-END_HALF[0], 0, ANCHOR_DZ]
            parent = parts[-1]
            for i, (kind, axis, limit) in enumerate(hinges):
                last = i == len(hinges) - 1
                if not last:
                    link = ab.create_link_builder(parent)
                    link.set_name(f"{kind}{k}")
                    link.set_mass_and_inertia(**tiny)
                elif k < N_LINKS:
                    link = ab.create_link_builder(parent)
                    link.set_name(f"link{k}")
                    link.collision_groups = [1, 1, ROPE_GROUP, 0]
                    capsule = {"radius": LINK_R, "half_length": SPACING / 2}
                    link.add_capsule_collision(**capsule, material=physical(LINK_FRICTION), density=LINK_DENSITY)
                    link.add_capsule_visual(**capsule, material=grey)
                else:
                    link = end_block(parent, "blue", "tail")
                link.set_joint_name(f"{kind}{k}")
                in_parent = sapien.Pose(anchor if i == 0 else [0, 0, 0], axis)
                in_child = sapien.Pose(child if last else [0, 0, 0], axis)
                link.set_joint_properties("revolute", [[-limit, limit]], in_parent, in_child)
                parent = link
            parts.append(parent)
            anchor = [SPACING / 2, 0, 0]
        names = {"head": "rope head", "tail": "rope tail"}
        self.rope = self.objects.articulation(ab, names, "rope", fix_root=False)
        links = {link.name: link for link in self.rope.get_links()}
        self.head, self.tail = links["head"], links["tail"]
        # never let the rope sleep: a sleeping articulation woken by the gripper jumps (PhysX)
        self.rope.set_sleep_threshold(0.0)
        for joint in self.rope.get_active_joints():
            joint.set_drive_property(0.0, JOINT_DAMPING)  # pure damping: calms the rope, no spring

        self.zones = []
        for colour, name in (((0.95, 0.55, 0.55), "head target"), ((0.55, 0.65, 0.95), "tail target")):
            b = scene.create_actor_builder()
            b.add_box_collision(sapien.Pose([0, 0, -0.006]), half_size=[ZONE_R, ZONE_R, 0.005])  # under the top
            add_cylinder(b, ZONE_R, 0.0005, sapien.Pose([0, 0, 0.0005]), colour, collide=False)
            self.zones.append(self.objects.actor(b, name, kind="static"))

    # --- episode ---------------------------------------------------------------------------
    @staticmethod
    def _shape(rng: np.random.Generator) -> np.ndarray:
        """Yaw angles of the N_LINKS + 1 joints: a gentle C or S curve."""
        n = N_LINKS + 1
        if rng.random() < 0.5:
            bends = np.full(n, np.deg2rad(rng.uniform(110.0, 170.0)) / n)
        else:
            half = n // 2
            first, second = np.deg2rad(rng.uniform(120.0, 170.0, 2))
            bends = np.concatenate([np.full(half, first / half), np.full(n - half, -second / (n - half))])
        bends *= rng.choice([-1.0, 1.0])
        return bends + np.deg2rad(rng.uniform(-4.0, 4.0, n))

    @staticmethod
    def _rlbench_shape() -> np.ndarray:
        """Yaw angles of the joints of the one rope shape of simulator.scenes: rlbench."""
        n, half = N_LINKS + 1, (N_LINKS + 1) // 2
        return np.concatenate([np.full(half, RLBENCH_BEND / half), np.full(n - half, -RLBENCH_BEND / (n - half))])

    @staticmethod
    def _tail_in_head_frame(bends: np.ndarray) -> np.ndarray:
        """Tail centre (x, y) with the head at the origin facing +x."""
        p, a = np.array([END_HALF[0], 0.0]), 0.0
        for k, b in enumerate(bends):
            a += b
            p = p + (SPACING if k < N_LINKS else END_HALF[0]) * np.array([np.cos(a), np.sin(a)])
        return p

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        self.variation = 0
        self.episode_instruction = self.instruction
        fixed = self.rlbench_scenes
        bends = self._rlbench_shape() if fixed else self._shape(rng)
        tail = self._tail_in_head_frame(bends)
        chord_yaw = float(np.arctan2(tail[1], tail[0]))
        for _ in range(200):
            mid = np.array([rng.uniform(0.17, 0.27), rng.uniform(-0.10, 0.10)])
            yaw = rng.uniform(-np.pi, np.pi)
            turn = yaw - chord_yaw
            rot = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
            head_xy = mid - rot @ (tail / 2)
            tail_xy = mid + rot @ (tail / 2)
            axis = yaw + (RLBENCH_ZONE_TURN if fixed else np.deg2rad(rng.uniform(-30.0, 30.0)))
            centre = mid if fixed else mid + rng.uniform(-0.04, 0.04, 2)
            half = ZONE_D / 2 * np.array([np.cos(axis), np.sin(axis)])
            targets = (centre - half, centre + half)
            inside = all(0.02 <= p[0] <= 0.42 and abs(p[1]) <= 0.3 for p in (*targets, head_xy, tail_xy))
            gaps = (np.linalg.norm(head_xy - targets[0]), np.linalg.norm(tail_xy - targets[1]))
            apart = min(gaps) > ZONE_R + 0.01
            if inside and apart:
                break
        self.axis = float(axis)
        for zone, t in zip(self.zones, targets):
            zone.set_pose(yaw_pose(t[0], t[1], TABLE_TOP_Z, 0.0))
        self.rope.set_root_pose(yaw_pose(head_xy[0], head_xy[1], TABLE_TOP_Z + END_HALF[2] + 0.0005, turn))
        qpos = np.zeros(self.rope.dof)
        names = [j.name for j in self.rope.get_active_joints()]
        for k, b in enumerate(bends):
            qpos[names.index(f"bend{k}")] = b
        self.rope.set_qpos(qpos)
        self.rope.set_qvel(np.zeros(self.rope.dof))
        self.rope.set_root_linear_velocity([0, 0, 0])
        self.rope.set_root_angular_velocity([0, 0, 0])

    # --- success ---------------------------------------------------------------------------
    def end_in_zone(self, end, zone) -> bool:
        p, z = np.asarray(end.entity.pose.p), np.asarray(zone.pose.p)
        return bool(np.linalg.norm(p[:2] - z[:2]) < ZONE_R and p[2] < TABLE_TOP_Z + 0.03)

    def evaluate(self) -> bool:
        return self.end_in_zone(self.head, self.zones[0]) and self.end_in_zone(self.tail, self.zones[1])

    # --- demonstrator ----------------------------------------------------------------------
    def _grasp_point(self, end, outward: float) -> np.ndarray:
        """Over the end block, 5 mm towards its free end (fingers well clear of the links)."""
        return self.world_point(end.entity.pose, [outward * 0.005, 0, END_HALF[2] - 0.012])

    def _tcp_for(self, held: sapien.Pose, centre, yaw: float) -> np.ndarray:
        """TCP position that puts the held block's centre at `centre` with the hand at `yaw`."""
        rot = sapien.Pose(q=down_quat(yaw)).to_transformation_matrix()[:3, :3]
        return np.asarray(centre) - rot @ np.asarray(held.p)

    def demonstration(self):
        head_t, tail_t = (np.asarray(z.pose.p) for z in self.zones)
        rest_z = TABLE_TOP_Z + END_HALF[2]

        # 1) the head to its zone, turned to face the tail zone
        head = self.head.entity.pose
        turn = wrap(self.axis - yaw_of(head))
        turns = [0.0, turn / 2, turn] if abs(turn) > np.pi / 2 else [0.0, turn]
        yaws = hand_yaws(yaw_of(head), turns)
        grasp = snap_to_grid(self._grasp_point(self.head, -1.0))
        yield quantised(self.key(grasp + [0, 0, 0.08], down_quat(yaws[0]), True))
        yield quantised(self.key(grasp, down_quat(yaws[0]), False))
        held = self.world.robot.tcp_pose().inv() * self.head.entity.pose
        yield quantised(self.key(grasp + [0, 0, LIFT], down_quat(yaws[0]), False))
        start = np.asarray(self.head.entity.pose.p)
        goal = np.array([head_t[0], head_t[1], rest_z])
        for i, y in enumerate(yaws[1:], 1):
            centre = start + (goal - start) * i / (len(yaws) - 1)
            centre[2] = rest_z + LIFT
            yield quantised(self.key(snap_to_grid(self._tcp_for(held, centre, y)), down_quat(y), False))
        place = snap_to_grid(self._tcp_for(held, goal, yaws[-1]))
        yield quantised(self.key(place, down_quat(yaws[-1]), True))
        yield quantised(self.key(place + [0, 0, 0.06], down_quat(yaws[-1]), True))

        # 2) the tail: out to the zone distance, then round the head at that radius
        hub = np.asarray(self.head.entity.pose.p)
        tail = self.tail.entity.pose
        if not (np.isfinite(hub).all() and np.isfinite(tail.p).all()):
            return  # the rope's joints diverged (NaN poses): this demo fails, so its scene is redrawn
        here = np.asarray(tail.p)[:2] - hub[:2]
        a0 = float(np.arctan2(here[1], here[0]))
        offset = tail_t[:2] - hub[:2]
        radius, sweep = float(np.linalg.norm(offset)), wrap(float(np.arctan2(offset[1], offset[0])) - a0)
        n = max(1, int(np.ceil(abs(sweep) / SWING)))
        bearings = [a0 + sweep * j / n for j in range(n + 1)]
        turn0 = wrap(a0 - yaw_of(tail))  # turn the tail to point away from the head
        yaws = hand_yaws(yaw_of(tail), [0.0] + [turn0 + b - a0 for b in bearings])
        grasp = snap_to_grid(self._grasp_point(self.tail, 1.0))
        yield quantised(self.key(grasp + [0, 0, 0.08], down_quat(yaws[0]), True))
        yield quantised(self.key(grasp, down_quat(yaws[0]), False))
        held = self.world.robot.tcp_pose().inv() * self.tail.entity.pose
        last = None
        for b, y in zip(bearings, yaws[1:]):
            centre = [hub[0] + radius * np.cos(b), hub[1] + radius * np.sin(b), rest_z + LIFT]
            key = quantised(self.key(snap_to_grid(self._tcp_for(held, centre, y)), down_quat(y), False))
            if key != last:  # a short swing can land on the pulled-out pose's grid cell
                yield key
            last = key
        goal = np.array([tail_t[0], tail_t[1], rest_z])
        place = snap_to_grid(self._tcp_for(held, goal, yaws[-1]))
        yield quantised(self.key(place, down_quat(yaws[-1]), True))
        yield quantised(self.key(place + [0, 0, 0.06], down_quat(yaws[-1]), True))
