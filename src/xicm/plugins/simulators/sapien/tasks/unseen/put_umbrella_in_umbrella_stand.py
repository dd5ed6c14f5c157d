"""put_umbrella_in_umbrella_stand (unseen, level 1).

Task description:
    A closed umbrella (folded navy canopy, metal tip, short shaft and a wooden handle) stands
    upright on its tip on the table next to an umbrella stand, an open-topped round bucket.
    The robot grips the umbrella's handle from above, lifts it high enough for
    the tip to clear the stand's rim, carries it over the stand, lowers it into the stand and
    lets go of it.

Randomisations:
    - umbrella centre x in [0.00, 0.14] m, y in [-0.25, 0.25] m, random yaw;
    - stand centre x in [0.24, 0.32] m, y in [-0.15, 0.15] m, random yaw, at least 0.18 m
      from the umbrella.

Success conditions:
    The umbrella is in the stand (its tip inside the stand: within the stand's inner radius
    of its axis and below its rim) AND nothing is grasped.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, add_cylinder, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, down_quat, quantised

# the umbrella along its local z, tip at z = 0
CANOPY_R, CANOPY_TOP = 0.022, 0.20  # folded canopy (with the tip: the part it stands on)
SHAFT_R, SHAFT_TOP = 0.006, 0.22
HANDLE_R, HANDLE_TOP = 0.013, 0.29
GRIP_Z = 0.265  # the TCP at this height of the umbrella when holding it (the palm clears the top)
STAND_R, STAND_H, WALL = 0.06, 0.12, 0.006  # stand: outer radius, height, wall thickness
FLOOR = 0.006
SEGMENTS = 16
SPAWN_UMBRELLA = ((0.0, 0.14), (-0.25, 0.25))
SPAWN_STAND = ((0.24, 0.32), (-0.15, 0.15))
MIN_GAP = 0.18


class PutUmbrellaInUmbrellaStand(Task):
    name = "put_umbrella_in_umbrella_stand"
    max_control_steps = 90  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "level1"
    instruction = "put umbrella in umbrella stand"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "put umbrella in umbrella stand",
        "pick up the umbrella and drop it in its stand",
        "use the handle to lift the umbrella and place it in its holder",
        "set the umbrella down inside the umbrella stand",
    )
    object_names = ("umbrella", "umbrella stand")

    def load(self) -> None:
        ab = self.world.scene.create_articulation_builder()
        body = ab.create_link_builder()
        body.set_name("stand")
        green = look((0.12, 0.30, 0.22), roughness=0.4, metallic=0.4)
        add_cylinder(body, STAND_R, FLOOR / 2, sapien.Pose([0, 0, FLOOR / 2]), green)
        mid = STAND_R - WALL / 2
        half_w = STAND_R * np.tan(np.pi / SEGMENTS)
        for k in range(SEGMENTS):
            phi = 2 * np.pi * k / SEGMENTS
            turn = [np.cos(phi / 2), 0, 0, np.sin(phi / 2)]
            pose = sapien.Pose([mid * np.cos(phi), mid * np.sin(phi), STAND_H / 2], turn)
            add_box(body, [WALL / 2, half_w, STAND_H / 2], pose, green, material=physical(0.8))
            band = pose * sapien.Pose([0.0035, 0, STAND_H / 2 - 0.012])  # a brass band below the rim
            add_box(body, [0.0005, half_w * 1.02, 0.006], band, (0.75, 0.62, 0.25), collide=False)
        self.stand = self.objects.articulation(ab, {"stand": "umbrella stand"}, "umbrella stand")

        b = self.world.scene.create_actor_builder()
        navy = look((0.08, 0.10, 0.35), roughness=0.7)
        metal = look((0.75, 0.75, 0.78), roughness=0.25, metallic=0.9)
        wood = look((0.40, 0.22, 0.10), roughness=0.5)
        grip = physical(1.5)
        # collision: a flat-bottomed cylinder it stands on, the shaft and the handle
        b.add_cylinder_collision(pose=self._along_z(CANOPY_TOP / 2), radius=CANOPY_R, half_length=CANOPY_TOP / 2,
                                 material=grip, density=250.0)
        b.add_cylinder_collision(pose=self._along_z((CANOPY_TOP + SHAFT_TOP) / 2), radius=SHAFT_R,
                                 half_length=(SHAFT_TOP - CANOPY_TOP) / 2, material=grip, density=900.0)
        b.add_cylinder_collision(pose=self._along_z((SHAFT_TOP + HANDLE_TOP) / 2), radius=HANDLE_R,
                                 half_length=(HANDLE_TOP - SHAFT_TOP) / 2, material=grip, density=500.0)
        # look: metal tip, a canopy folded into a taper, a strap, the shaft and the handle
        b.add_cylinder_visual(pose=self._along_z(0.015), radius=0.005, half_length=0.015, material=metal)
        for i, (z0, z1) in enumerate(((0.03, 0.07), (0.07, 0.12), (0.12, 0.16), (0.16, CANOPY_TOP))):
            r = CANOPY_R * (0.55 + 0.15 * i)
            b.add_cylinder_visual(pose=self._along_z((z0 + z1) / 2), radius=r, half_length=(z1 - z0) / 2, material=navy)
        b.add_cylinder_visual(pose=self._along_z(0.10), radius=CANOPY_R * 0.75, half_length=0.008,
                              material=look((0.75, 0.65, 0.20), roughness=0.4))
        b.add_cylinder_visual(pose=self._along_z((CANOPY_TOP + SHAFT_TOP) / 2), radius=SHAFT_R,
                              half_length=(SHAFT_TOP - CANOPY_TOP) / 2, material=metal)
        b.add_cylinder_visual(pose=self._along_z((SHAFT_TOP + HANDLE_TOP) / 2), radius=HANDLE_R,
                              half_length=(HANDLE_TOP - SHAFT_TOP) / 2, material=wood)
        b.add_sphere_visual(pose=sapien.Pose([0, 0, HANDLE_TOP]), radius=HANDLE_R, material=wood)
        self.umbrella = self.objects.actor(b, "umbrella")

    @staticmethod
    def _along_z(z: float) -> sapien.Pose:
        """Pose of a SAPIEN cylinder (along its x axis) standing along z, centred at height z."""
        return sapien.Pose([0, 0, z], [np.cos(np.pi / 4), 0, -np.sin(np.pi / 4), 0])

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        umbrella = np.array([rng.uniform(*SPAWN_UMBRELLA[0]), rng.uniform(*SPAWN_UMBRELLA[1])])
        while True:
            stand = np.array([rng.uniform(*SPAWN_STAND[0]), rng.uniform(*SPAWN_STAND[1])])
            if np.linalg.norm(stand - umbrella) >= MIN_GAP:
                break
        self.stand.set_root_pose(yaw_pose(*stand, TABLE_TOP_Z, rng.uniform(-np.pi, np.pi)))
        self.umbrella.set_pose(yaw_pose(*umbrella, TABLE_TOP_Z + 0.001, rng.uniform(-np.pi, np.pi)))
        body = self.umbrella.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
        body.set_linear_velocity([0, 0, 0])
        body.set_angular_velocity([0, 0, 0])
        self.variation = 0
        self.episode_instruction = self.instruction

    def tip(self) -> np.ndarray:
        return np.asarray(self.umbrella.pose.p, dtype=float)  # the actor's origin is its tip

    def in_stand(self) -> bool:
        tip = self.tip()
        base = np.asarray(self.stand.get_root_pose().p, dtype=float)
        off = np.linalg.norm(tip[:2] - base[:2])
        return bool(off < STAND_R - WALL and tip[2] < base[2] + STAND_H)

    def evaluate(self) -> bool:
        return self.in_stand() and not self.grasped()

    def demonstration(self):
        q = down_quat(0.0)
        grasp = self.tip() + [0.0, 0.0, GRIP_Z]
        yield quantised(self.key(grasp + [0, 0, 0.06], q, True))
        yield quantised(self.key(grasp, q, False))
        # lift until the tip is 3 cm above the stand's rim, then over the stand's axis
        tcp = np.asarray(self.world.robot.tcp_pose().p, dtype=float)
        in_hand = tcp - self.tip()
        base = np.asarray(self.stand.get_root_pose().p, dtype=float)
        high = base[2] + STAND_H + 0.03 + in_hand[2]
        yield quantised(self.key([grasp[0], grasp[1], high], q, False))
        over = base + [in_hand[0], in_hand[1], 0.0]
        yield quantised(self.key([over[0], over[1], high], q, False))
        # down until the tip is 2 cm above the stand's floor, let go, back off upwards
        low = base[2] + FLOOR + 0.02 + in_hand[2]
        yield quantised(self.key([over[0], over[1], low], q, False))
        yield quantised(self.key([over[0], over[1], low], q, True))
        yield quantised(self.key([over[0], over[1], high], q, True))
