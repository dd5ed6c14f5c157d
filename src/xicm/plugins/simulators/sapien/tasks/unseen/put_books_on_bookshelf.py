"""put_books_on_bookshelf (unseen, level 1).

Task description:
    Three books (red, blue and green hardbacks) stand upright on the table in front of a low
    wooden bookshelf: a lower compartment under the top shelf, and the top shelf itself with
    low side walls and a back. The robot picks the first book up by its top edge, carries it
    over the top shelf, sets it down standing on the shelf and lets go of it; for more books
    it does the same with the next ones, side by side.

Randomisations:
    - book centres x in [0.00, 0.16] m, y in [-0.26, 0.26] m, at least 0.12 m apart, each
      with yaw in [-30, 30] degrees (the spine towards the robot or away from it);
    - bookshelf centre x in [0.32, 0.38] m, y in [-0.08, 0.08] m, yaw in [-90, 90] degrees
      (RLBench's base_rotation_bounds; at 0 the open front faces the robot).

Success conditions:
    The first N books (variation 0, evaluated: N = 1) rest on the top shelf: each book's
    centre over the shelf and at most 2 cm higher than a book standing on it.
"""

from __future__ import annotations

import numpy as np
import sapien

from ...objects import add_box, look, physical, yaw_pose
from ...scene import TABLE_TOP_Z
from ...task_base import Task, down_quat, half_turn, quantised, yaw_of

BOOK_HALF = (0.05, 0.0125, 0.07)  # half depth (x), thickness (y) and height (z) of a book
BOOK_COLOURS = ((0.70, 0.10, 0.10), (0.10, 0.20, 0.65), (0.10, 0.45, 0.20))
SHELF_HALF = (0.08, 0.18)  # outer half depth and width of the bookshelf
TOP = 0.12  # the top shelf's surface above the table
BOARD = 0.015  # board thickness
RAIL = 0.05  # height of the top shelf's side walls and back above its surface
GRIP_DEPTH = 0.02  # the TCP this far below a book's top when holding it
SLOTS = (0.0, 0.06, -0.06)  # where the demonstrator stands books 1, 2, 3 along the shelf
SPAWN_BOOKS = ((0.0, 0.16), (-0.26, 0.26), 0.12)
SPAWN_SHELF = ((0.32, 0.38), (-0.08, 0.08), 90.0)



class PutBooksOnBookshelf(Task):
    name = "put_books_on_bookshelf"
    max_control_steps = 94  # 2 x the longest scripted demo (benchmarks/demo_lengths.py)
    split = "level1"
    instruction = "put 1 books on bookshelf"
    #: every variation-0 phrasing RLBench's task gives (the instruction first), for benchmark.instructions
    phrasings = (
        "put 1 books on bookshelf",
        "put books on bookshelf",
        "pick up the books and place them on the top shelf",
        "stack the books up on the top shelf",
    )
    object_names = ("book 1", "book 2", "book 3", "bookshelf", "top shelf")

    def load(self) -> None:
        wood = look((0.55, 0.36, 0.20), roughness=0.6)
        ab = self.world.scene.create_articulation_builder()
        body = ab.create_link_builder()
        body.set_name("bookshelf")
        hx, hy = SHELF_HALF
        height = TOP + RAIL
        add_box(body, [hx, hy, BOARD / 2], sapien.Pose([0, 0, BOARD / 2]), wood)  # bottom shelf
        for s in (-1, 1):
            add_box(body, [hx, BOARD / 2, height / 2], sapien.Pose([0, s * (hy - BOARD / 2), height / 2]), wood)
        add_box(body, [BOARD / 2, hy - BOARD, height / 2], sapien.Pose([hx - BOARD / 2, 0, height / 2]), wood)
        top = ab.create_link_builder(body)
        top.set_name("top_shelf")
        top.set_joint_name("top_shelf_joint")
        top.set_joint_properties("fixed", [], sapien.Pose([0, 0, TOP - BOARD / 2]), sapien.Pose())
        add_box(top, [hx - BOARD / 2, hy - BOARD, BOARD / 2], sapien.Pose([-BOARD / 2, 0, 0]),
                look((0.62, 0.42, 0.24), roughness=0.6), material=physical(1.0))
        self.shelf = self.objects.articulation(ab, {"bookshelf": "bookshelf", "top_shelf": "top shelf"}, "bookshelf")

        self.books = []
        hx, hy, hz = BOOK_HALF
        for i, colour in enumerate(BOOK_COLOURS):
            b = self.world.scene.create_actor_builder()
            add_box(b, BOOK_HALF, None, look(colour, roughness=0.5), material=physical(1.2), density=600.0)
            # cream page edges on the three sides away from the spine (the spine faces -x)
            pages = look((0.95, 0.92, 0.82), roughness=0.9)
            b.add_box_visual(pose=sapien.Pose([hx + 0.0005, 0, 0]), half_size=[0.0006, hy - 0.002, hz - 0.003],
                             material=pages)
            for s in (-1, 1):
                b.add_box_visual(pose=sapien.Pose([0.002, 0, s * (hz + 0.0005)]),
                                 half_size=[hx - 0.002, hy - 0.002, 0.0006], material=pages)
            b.add_box_visual(pose=sapien.Pose([-hx - 0.0005, 0, hz * 0.5]), half_size=[0.0006, hy * 0.7, 0.012],
                             material=look((0.90, 0.80, 0.30), roughness=0.3, metallic=0.6))  # title on the spine
            self.books.append(self.objects.actor(b, f"book {i + 1}"))
        self.count = 1

    def initialise(self, rng: np.random.Generator, sample_variation: bool) -> None:
        (xs, ys, gap), (sxs, sys_, syaw) = SPAWN_BOOKS, SPAWN_SHELF
        spots: list[np.ndarray] = []
        while len(spots) < len(self.books):
            p = np.array([rng.uniform(*xs), rng.uniform(*ys)])
            if all(np.linalg.norm(p - q) >= gap for q in spots):
                spots.append(p)
        for book, spot in zip(self.books, spots):
            yaw = np.deg2rad(rng.uniform(-30.0, 30.0)) + (np.pi if rng.integers(2) else 0.0)
            book.set_pose(yaw_pose(*spot, TABLE_TOP_Z + BOOK_HALF[2] + 0.001, yaw))
            body = book.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
            body.set_linear_velocity([0, 0, 0])
            body.set_angular_velocity([0, 0, 0])
        shelf_xy = rng.uniform(*sxs), rng.uniform(*sys_)
        self.shelf_pose = yaw_pose(*shelf_xy, TABLE_TOP_Z, np.deg2rad(rng.uniform(-syaw, syaw)))
        self.shelf.set_root_pose(self.shelf_pose)
        self.count = 1  # variation 0: "put 1 books on bookshelf"
        self.variation = 0
        self.episode_instruction = self.instruction

    def on_top_shelf(self, index: int) -> bool:
        local = np.asarray((self.shelf_pose.inv() * self.books[index].pose).p, dtype=float)
        hx, hy = SHELF_HALF
        over = -hx < local[0] < hx - BOARD and abs(local[1]) < hy - BOARD
        return bool(over and TOP < local[2] < TOP + BOOK_HALF[2] + 0.02)

    def evaluate(self) -> bool:
        return all(self.on_top_shelf(i) for i in range(self.count))

    def demonstration(self):
        for i in range(self.count):
            yield from self._shelve(i)

    def _shelve(self, index: int):
        book = self.books[index]
        centre = np.asarray(book.pose.p, dtype=float)
        q = down_quat(half_turn(yaw_of(book.pose)))  # fingers close across the book's thickness
        grasp = centre + [0.0, 0.0, BOOK_HALF[2] - GRIP_DEPTH]
        yield quantised(self.key(grasp + [0, 0, 0.06], q, True))
        yield quantised(self.key(grasp, q, False))
        # carry it with its bottom 2 cm above the shelf's walls
        tcp = self.world.robot.tcp_pose()
        in_hand = book.pose.inv() * tcp
        carry = TABLE_TOP_Z + TOP + RAIL + 0.02 + in_hand.p[2] + BOOK_HALF[2]
        yield quantised(self.key([grasp[0], grasp[1], carry], q, False))
        # stand it on the shelf, its depth along the shelf's, turned by less than 90 degrees;
        # either way round, so that the wrist stays near its start turn
        turn = half_turn(yaw_of(self.shelf_pose) - yaw_of(book.pose))
        hand_yaw = yaw_of(tcp)
        if abs(hand_yaw + turn) > np.pi / 2:
            turn -= np.sign(hand_yaw + turn) * np.pi
        spot = self.world_point(self.shelf_pose, [-BOARD / 2, SLOTS[index], TOP + BOOK_HALF[2] + 0.005])
        target = yaw_pose(*spot, yaw_of(book.pose) + turn)
        place = target * in_hand
        yield quantised(self.key([place.p[0], place.p[1], carry], place.q, False))
        yield quantised(self.key(place.p, place.q, True))
        yield quantised(self.key([place.p[0], place.p[1], carry], place.q, True))
