"""beat_the_buzz (unseen, level 2).

Task description:
    A buzz-wire game stands on the table: a straight brass wire stretched between two black
    posts on a wooden base, running from left to right (seen from the robot). Under the wire,
    near each post, stands a rest pad: the green "start rest" and the red "end rest". A wand (a
    square ring on a short foot, with a red handle on top) is threaded on the wire and stands on
    the start rest. The robot takes the handle from above, lifts the ring to centre it on the
    wire, carries it along the wire to the end rest without touching the wire, sets it down
    there and lets go.

Randomisations:
    - wire centre x in [0.26, 0.34] m, y in [-0.06, 0.06] m, yaw in [-30, 30] degrees (RLBench's
      default is [-180, 180]; at +-45 the demonstrator fails 3 of 40 seeds, at +-180 7 of 20: the
      carry along a wire turned towards the robot leaves the wrist's range;
      simulator.scenes: rlbench draws [-180, 180] and redraws scenes the demonstrator fails);
    - which end (left or right) is the start.

Success conditions:
    The wand's ring is over the end rest (around the wire), the wand touched the wire at the
    end of no key action or step (as RLBench, which reads its fail condition after each step
    and then ends the episode; a touch during a move that has gone by then does not count),
    AND the gripper holds nothing.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, down_quat, snap_to_grid

HALF_SPAN = 0.20  # post centre to wire centre, along the wire
POST_R = 0.012
WIRE_H = 0.18  # wire axis above the table
WIRE_R = 0.004
RING_IN = 0.03  # half size of the square opening of the ring
RING_BAR = 0.008  # width of the ring's bars in the ring plane
RING_HALF_T = 0.005  # half thickness of the ring along the wire
FOOT_HALF = (RING_IN + RING_BAR, 0.03, 0.004)  # flat foot under the ring: the wand stands on it
HANDLE_HALF = (0.008, 0.008, 0.05)
GRASP_DOWN = 0.02  # grasp point below the top of the handle
REST_DROP = 0.015  # a standing wand's ring centre is this far below the wire axis
RING_AT = 0.14  # rest pad centres, along the wire from its centre
PAD_HALF = (0.045, 0.04)  # rest pad half sizes across / along the wire
# the wand in its own frame: ring centre at the origin, ring in the x-z plane
FOOT_Z = -RING_IN - RING_BAR - FOOT_HALF[2]
PAD_TOP = WIRE_H - REST_DROP + FOOT_Z - FOOT_HALF[2]  # pad top above the table
STEP = np.deg2rad(5.0)


class BeatTheBuzz(Task):
    name = "beat_the_buzz"
    max_control_steps = 76  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "level2"
    instruction = "beat the buzz"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "beat the buzz",
        "slide the ring along the pole without allowing them to touch",
        "slide the ring along the metal pole, avoiding contact between them",
        "slide the ring from one end of the pole to the other without allowing them to touch",
        "slide the ring from one end of the pole to the other, avoiding contact between them",
        "move the ring from one end of the pole to the other, maintaining a gap between them",
        "move the ring from end of the pole to the other whilst maintaining separation between them",
    )
    object_names = ("wand", "buzz wire", "start rest", "end rest")

    def load(self) -> None:
        scene = self.world.scene
        b = scene.create_actor_builder()
        brass = look((0.75, 0.62, 0.35), roughness=0.3, metallic=0.8)
        add_cylinder(b, WIRE_R, HALF_SPAN, color=brass, axis="y")
        self.wire = self.objects.actor(b, "buzz wire", kind="static")
        self.rests = []
        for name, colour in (("start rest", "green"), ("end rest", "red")):
            b = scene.create_actor_builder()
            add_box(b, [PAD_HALF[0], PAD_HALF[1], PAD_TOP / 2], sapien.Pose([0, 0, PAD_TOP / 2]), colour,
                    material=physical(1.0))
            self.rests.append(self.objects.actor(b, name, kind="static"))
        b = scene.create_actor_builder()
        add_box(b, [0.05, HALF_SPAN + 0.03, 0.0075], sapien.Pose([0, 0, 0.0075]), (0.55, 0.38, 0.2))  # base
        post_half = (WIRE_H + 0.015) / 2  # posts stand a little above the wire: the ring cannot slip off
        for s in (-1, 1):
            add_cylinder(b, POST_R, post_half, sapien.Pose([0, s * HALF_SPAN, post_half]), "black")
        self.stand = self.objects.actor(b, "buzz wire stand", kind="static")

        b = scene.create_actor_builder()
        chrome = look((0.8, 0.8, 0.82), roughness=0.3, metallic=0.7)
        outer = RING_IN + RING_BAR
        for s in (-1, 1):
            add_box(b, [outer, RING_HALF_T, RING_BAR / 2], sapien.Pose([0, 0, s * (RING_IN + RING_BAR / 2)]), chrome,
                    density=300.0)
            add_box(b, [RING_BAR / 2, RING_HALF_T, RING_IN], sapien.Pose([s * (RING_IN + RING_BAR / 2), 0, 0]), chrome,
                    density=300.0)
        add_box(b, FOOT_HALF, sapien.Pose([0, 0, FOOT_Z]), chrome, material=physical(1.0), density=300.0)
        add_box(b, HANDLE_HALF, sapien.Pose([0, 0, outer + HANDLE_HALF[2]]), "red", material=physical(1.5),
                density=300.0)
        self.wand = self.objects.actor(b, "wand")

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        x, y = rng.uniform(0.26, 0.34), rng.uniform(-0.06, 0.06)
        self.yaw = float(np.deg2rad(rng.uniform(*self.span(ours=(-30.0, 30.0), rlbench=(-180.0, 180.0)))))
        self.start_side = 1.0 if rng.random() < 0.5 else -1.0  # along-wire sign of the start end
        self.frame = yaw_pose(x, y, TABLE_TOP_Z, self.yaw)  # wire frame: wire along local y
        self.stand.set_pose(self.frame)
        self.wire.set_pose(self.frame * sapien.Pose([0, 0, WIRE_H]))
        for rest, side in zip(self.rests, (self.start_side, -self.start_side)):
            rest.set_pose(self.frame * sapien.Pose([0, side * RING_AT, 0]))
        self.wand.set_pose(self.frame * sapien.Pose([0, self.start_side * RING_AT, WIRE_H - REST_DROP]))
        body = self.wand.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
        body.set_linear_velocity([0, 0, 0])
        body.set_angular_velocity([0, 0, 0])
        self.touched = False
        self.variation = 0
        self.episode_instruction = self.instruction

    def _local(self, p) -> np.ndarray:
        return np.asarray((self.frame.inv() * sapien.Pose(np.asarray(p, dtype=float))).p, dtype=float)

    def wand_touches_wire(self) -> bool:
        pair = {self.wand.per_scene_id, self.wire.per_scene_id}
        for contact in self.world.scene.get_contacts():
            ids = {contact.bodies[0].entity.per_scene_id, contact.bodies[1].entity.per_scene_id}
            if ids == pair and any(p.separation < 5e-4 or abs(p.impulse).sum() > 1e-6 for p in contact.points):
                return True
        return False

    def on_step_end(self) -> None:
        # RLBench reads its fail condition (the wand in the wire's sensor) after each step and
        # then ends the episode as a failure; a touch during a move that has gone by then is not one
        if not self.touched and self.wand_touches_wire():
            self.touched = True

    def at_end(self) -> bool:
        """The ring is over the end rest, around the wire."""
        local = self._local(self.wand.pose.p)
        over_rest = abs(-self.start_side * local[1] - RING_AT) < PAD_HALF[1]
        around = abs(local[0]) < RING_IN and abs(local[2] - WIRE_H) < RING_IN
        return bool(over_rest and around)

    def evaluate(self) -> bool:
        return self.at_end() and not self.touched and not self.grasped()

    def demonstration(self):
        q = down_quat(float(np.round(self.yaw / STEP) * STEP))  # fingers close along the wire
        top = RING_IN + RING_BAR + 2 * HANDLE_HALF[2]
        grasp = snap_to_grid(self.world_point(self.wand.pose, [0, 0, top - GRASP_DOWN]))
        yield self.key(grasp + [0, 0, 0.08], q, True)
        yield self.key(grasp, q, False)
        ring_from_tcp = np.asarray(self.wand.pose.p) - np.asarray(self.world.robot.tcp_pose().p)
        s = self.start_side

        def tcp_for(along: float) -> np.ndarray:
            """TCP position putting the ring centre on the wire axis at `along`."""
            return snap_to_grid(self.world_point(self.frame, [0, along, WIRE_H]) - ring_from_tcp)

        yield self.key(tcp_for(s * RING_AT), q, False)  # lift: ring centred on the wire
        yield self.key(tcp_for(-s * RING_AT), q, False)  # along the wire, over the end rest
        # down until the foot is 1 to 11 mm above the pad (the grid cell above), then let go
        put = tcp_for(-s * RING_AT)
        stand_z = self.world_point(self.frame, [0, 0, WIRE_H - REST_DROP])[2] - ring_from_tcp[2]
        put[2] += np.ceil((stand_z + 0.001 - put[2]) / 0.01) * 0.01
        yield self.key(put, q, True)
        yield self.key(put + [0, 0, 0.08], q, True)
