"""insert_onto_square_peg (seen).

Task description:
    A base with three coloured square pegs (spokes) in a row stands on the table, and a square
    ring lies flat on the table in front of it. The robot picks the ring up by one of its sides
    and drops it over the spoke of the named colour, so that the ring goes round the spoke.

Randomisations:
    - when variations are sampled: the three spoke colours (from eight) and which of them is
      the target. Variation 0 is red, green, blue with the red spoke as the target;
    - base yaw in [-180, 180] degrees (RLBench's default base_rotation_bounds), centre x in
      [0.30, 0.40] m less 0.06 m x |sin(yaw)| (keeps the far spoke in reach), y in [-0.10, 0.10] m;
    - ring centre x in [0.06, 0.14] m, y in [-0.20, 0.20] m (redrawn while within 8.4 cm of the
      base's footprint), yaw in [-45, 45] degrees.

Success conditions:
    The ring is round the named spoke: its centre within 2.5 cm of the spoke's axis and below
    the spoke's top by more than 3 cm.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, frame_quat, needs_turn, turn_gripper

PALETTE = ("red", "green", "blue", "yellow", "orange", "purple", "cyan", "white")
BASE_HALF = (0.05, 0.19, 0.01)
SPOKE_HALF, SPOKE_H = 0.010, 0.08  # square cross-section half size and height above the base
SPOKE_GAP = 0.12  # between neighbouring spokes
RING_OUT, RING_IN, RING_H = 0.045, 0.030, 0.03  # outer and inner half size, thickness
BAR = (RING_OUT + RING_IN) / 2  # distance of a side bar's middle from the ring centre
GRASP_Z = 0.025  # TCP height above the table when grasping (pads clear of the table)
CLEAR = 0.03  # ring bottom above the spoke tops while carrying


class InsertOntoSquarePeg(Task):
    name = "insert_onto_square_peg"
    max_control_steps = 80  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "seen"
    instruction = "put the ring on the red spoke"
    phrasings = (  # RLBench's variation-0 phrasings, AGNOSTOS's instruction first
        "put the ring on the red spoke",
        "slide the ring onto the red colored spoke",
        "place the ring onto the red spoke",
    )
    object_names = ("square ring", "red spoke", "green spoke", "blue spoke")

    def load(self) -> None:
        """The spokes are coloured per episode; see initialise()."""
        rb = self.world.scene.create_actor_builder()
        wood = look((0.85, 0.70, 0.45), roughness=0.7)
        mat = physical(1.5)
        for k in range(4):  # four side bars make the square ring
            c, s = np.cos(k * np.pi / 2), np.sin(k * np.pi / 2)
            half = [(RING_OUT - RING_IN) / 2, RING_OUT, RING_H / 2] if k % 2 == 0 else \
                [RING_OUT - (RING_OUT - RING_IN), (RING_OUT - RING_IN) / 2, RING_H / 2]
            pose = sapien.Pose([BAR * c, BAR * s, 0.0])
            rb.add_box_collision(pose=pose, half_size=half, material=mat, density=600.0)
            rb.add_box_visual(pose=pose, half_size=half, material=wood)
        self.ring = self.objects.actor(rb, "square ring")
        self.base = None

    def _build_base(self, colours: list[str], pose: sapien.Pose):
        ab = self.world.scene.create_articulation_builder()
        base = ab.create_link_builder()
        base.set_name("base")
        add_box(base, BASE_HALF, sapien.Pose([0, 0, BASE_HALF[2]]), (0.35, 0.25, 0.18))
        links = {"base": "spoke base"}
        for i, colour in enumerate(colours):
            spoke = ab.create_link_builder(base)
            spoke.set_name(f"spoke_{i}")
            spoke.set_joint_name(f"spoke_{i}_joint")
            at = sapien.Pose([0, (i - 1) * SPOKE_GAP, 2 * BASE_HALF[2]])
            spoke.set_joint_properties("fixed", [], at, sapien.Pose())
            add_box(spoke, [SPOKE_HALF, SPOKE_HALF, SPOKE_H / 2], sapien.Pose([0, 0, SPOKE_H / 2]), colour)
            links[f"spoke_{i}"] = f"{colour} spoke"
        return self.objects.articulation(ab, links, "spoke base", pose)

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        colours = [PALETTE[i] for i in rng.choice(len(PALETTE), 3, replace=False)]
        target = int(rng.integers(3))
        if not sample_variation:
            colours, target = ["red", "green", "blue"], 0
        self.colours, self.target = colours, target
        self.variation = 0 if (colours, target) == (["red", "green", "blue"], 0) else 1
        self.episode_instruction = f"put the ring on the {colours[target]} spoke"
        self.episode_object_names = ["square ring", *(f"{c} spoke" for c in colours)]
        yaw = np.deg2rad(rng.uniform(-180.0, 180.0))
        # a base turned with its spokes along x moves nearer, so the far spoke stays in reach
        x = rng.uniform(0.30, 0.40) - 0.06 * abs(np.sin(yaw))
        self.base_pose = yaw_pose(x, rng.uniform(-0.10, 0.10), TABLE_TOP_Z, yaw)
        self.base = self._build_base(colours, self.base_pose)
        ring_yaw = np.deg2rad(rng.uniform(-45.0, 45.0))
        clear = RING_OUT * np.sqrt(2.0) + 0.02  # the ring's corner radius and a margin
        while True:  # a base turned across the table may reach into the ring's area
            ring_xy = np.array([rng.uniform(0.06, 0.14), rng.uniform(-0.20, 0.20)])
            local = self.world_point(self.base_pose.inv(), [*ring_xy, TABLE_TOP_Z])
            if abs(local[0]) > BASE_HALF[0] + clear or abs(local[1]) > BASE_HALF[1] + clear:
                break
        self.ring.set_pose(yaw_pose(*ring_xy, TABLE_TOP_Z + RING_H / 2 + 0.001, ring_yaw))
        body = self.ring.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
        body.set_linear_velocity([0, 0, 0])
        body.set_angular_velocity([0, 0, 0])

    def spoke_axis(self, index: int) -> np.ndarray:
        """World (x, y) of spoke `index`'s axis and the z of its top."""
        return self.world_point(self.base_pose, [0.0, (index - 1) * SPOKE_GAP, 2 * BASE_HALF[2] + SPOKE_H])

    def spoke_of_ring(self) -> int | None:
        """The spoke the ring is round, or None."""
        p = np.asarray(self.ring.pose.p, dtype=float)
        for i in range(3):
            top = self.spoke_axis(i)
            if np.linalg.norm(p[:2] - top[:2]) < 0.025 and p[2] < top[2] - 0.03:
                return i
        return None

    def evaluate(self) -> bool:
        return self.spoke_of_ring() == self.target

    def demonstration(self):
        pose = self.ring.pose
        rot = pose.to_transformation_matrix()[:3, :3]
        centre = np.asarray(pose.p, dtype=float)
        # the side bar nearest the robot; its outward normal is one of the ring's +-x / +-y axes
        sides = [rot[:, 0], rot[:, 1], -rot[:, 0], -rot[:, 1]]
        out = min(sides, key=lambda v: v[0])
        out = out * np.array([1.0, 1.0, 0.0]) / np.linalg.norm(out[:2])
        down = np.array([0.0, 0.0, -1.0])
        quat = frame_quat(np.cross(out, down), out, down)  # fingers close across the bar
        if needs_turn(quat):
            quat = turn_gripper(quat)
        grasp = centre + out * BAR
        grasp[2] = TABLE_TOP_Z + GRASP_Z
        offset = centre[:2] - grasp[:2]  # ring centre relative to the TCP, kept while carrying
        yield self.key(grasp + [0.0, 0.0, 0.10], quat, True)
        yield self.key(grasp, quat, False)
        top = self.spoke_axis(self.target)
        below_tcp = GRASP_Z  # ring bottom below the TCP
        carry = np.array([top[0] - offset[0], top[1] - offset[1], top[2] + CLEAR + below_tcp])
        yield self.key([grasp[0], grasp[1], carry[2]], quat, False)
        yield self.key(carry, quat, False)
        yield self.key(carry - [0.0, 0.0, CLEAR + 0.01], quat, True)  # ring just round the top
        yield self.key(carry, quat, True)
