"""Task-specific checks of the unseen SAPIEN tasks put_toilet_roll_on_stand, phone_on_base,
put_rubbish_in_bin, put_knife_on_chopping_board, put_books_on_bookshelf and
put_umbrella_in_umbrella_stand: plausible wrong outcomes are not a success.

Each test drives the task's own scripted demonstrator and changes some of its key actions
(keeps holding instead of letting go, puts the object down beside its target, or points the
demonstrator at the wrong object), then checks what the success test says.
"""

import numpy as np
import pytest

pytest.importorskip("sapien")

from xicm.core.types import KeyAction


def run_demo(sim, change=None) -> None:
    """Execute the current task's demonstration; `change(i, action)` may replace key action i."""
    for i, action in enumerate(sim.task.demonstration()):
        if change is not None:
            action = change(i, action)
        assert sim.execute(action).ok


def keep_holding(sim, release_index: int):
    """A demonstration that goes to its release pose but keeps the gripper closed there, and stops."""
    for i, action in enumerate(sim.task.demonstration()):
        if i == release_index:
            assert action.gripper_open and not sim.robot.gripper_open, "not the release key"
            assert sim.execute(KeyAction(action.position, action.quat_wxyz, False)).ok
            return action
        assert sim.execute(action).ok
    pytest.fail("the demonstrator never reached its release key")


def shifted(after: int, offset):
    """A change that moves every key action from index `after` on by `offset` metres."""

    def change(i, action):
        if i < after:
            return action
        return KeyAction(tuple(np.asarray(action.position) + offset), action.quat_wxyz, action.gripper_open)

    return change


def test_toilet_roll_held_on_the_post_or_dropped_beside_the_stand_is_not_a_success(sim):
    sim.reset_state("put_toilet_roll_on_stand", 0, 0)
    task = sim.task
    release = keep_holding(sim, 4)
    assert task.on_stand() and task.grasped()
    assert not sim.is_success()
    assert sim.execute(release).success  # letting go completes the task

    sim.reset_state("put_toilet_roll_on_stand", 1, 0)
    task = sim.task
    stand = task.post_axis()
    task.post_axis = lambda: stand + [0.0, 0.14 if stand[1] < 0 else -0.14, 0.0]  # aim beside the stand
    run_demo(sim)
    del task.post_axis  # the real stand again
    assert np.linalg.norm(np.asarray(task.roll.pose.p)[:2] - stand[:2]) > 0.08
    assert not task.on_stand() and not task.grasped()
    assert not sim.is_success()


def test_phone_held_in_the_cradle_or_put_beside_the_base_is_not_a_success(sim):
    sim.reset_state("phone_on_base", 0, 0)
    task = sim.task
    release = keep_holding(sim, 4)
    assert task.on_base() and task.grasped()
    assert not sim.is_success()
    assert sim.execute(release).success

    sim.reset_state("phone_on_base", 1, 0)
    task = sim.task
    base_y = float(task.base.get_root_pose().p[1])
    run_demo(sim, shifted(3, [0.0, -0.15 if base_y > 0 else 0.15, 0.0]))
    assert not task.on_base() and not task.grasped()
    assert not sim.is_success()


def test_a_tomato_in_the_bin_or_rubbish_beside_it_is_not_a_success(sim):
    sim.reset_state("put_rubbish_in_bin", 0, 0)
    task = sim.task
    rubbish = task.rubbish
    task.rubbish = task.tomatoes[0]  # the demonstrator bins a tomato instead
    run_demo(sim)
    task.rubbish = rubbish
    assert task.in_bin(task.tomatoes[0]) and not task.in_bin(rubbish)
    assert not sim.is_success()

    sim.reset_state("put_rubbish_in_bin", 1, 0)
    task = sim.task
    run_demo(sim, shifted(3, [-0.14, 0.0, 0.0]))  # dropped on the robot's side of the bin
    assert not task.in_bin(task.rubbish)
    assert not sim.is_success()


def test_knife_left_in_the_block_dropped_beside_the_board_or_still_held_is_not_a_success(sim):
    sim.reset_state("put_knife_on_chopping_board", 0, 0)
    task = sim.task
    # pulled half way out, then let go: it drops back into the block
    keys = task.demonstration()
    for _ in range(2):
        assert sim.execute(next(keys)).ok
    grasp = np.asarray(sim.robot.tcp_pose().p)
    assert sim.execute(task.key(grasp + [0, 0, 0.05], sim.robot.tcp_pose().q, False)).ok
    assert sim.execute(task.key(grasp + [0, 0, 0.05], sim.robot.tcp_pose().q, True)).ok
    assert not task.on_board() and not sim.is_success()

    sim.reset_state("put_knife_on_chopping_board", 1, 0)
    task = sim.task
    board_y = float(task.board.get_root_pose().p[1])
    run_demo(sim, shifted(5, [0.0, -0.22 if board_y > 0 else 0.22, 0.0]))
    assert not task.on_board() and not task.grasped()
    assert not sim.is_success()

    sim.reset_state("put_knife_on_chopping_board", 2, 0)
    task = sim.task
    run_demo(sim)
    assert sim.is_success()
    task.grasped = lambda: {task.knife.per_scene_id}  # "then nothing grasped" is part of success
    assert task.on_board() and not sim.is_success()


def test_wrong_book_or_book_in_front_of_the_shelf_is_not_a_success(sim):
    sim.reset_state("put_books_on_bookshelf", 0, 0)
    task = sim.task
    books = list(task.books)
    task.books = [books[1], books[0], books[2]]  # the demonstrator shelves book 2 instead of book 1
    run_demo(sim)
    task.books = books
    assert task.on_top_shelf(1) and not task.on_top_shelf(0)
    assert not sim.is_success()

    sim.reset_state("put_books_on_bookshelf", 1, 0)
    task = sim.task
    keys = task.demonstration()
    for _ in range(4):  # picked up and carried over the top shelf, not yet put down
        assert sim.execute(next(keys)).ok
    assert task.grasped() and not task.on_top_shelf(0)
    assert not sim.is_success()

    sim.reset_state("put_books_on_bookshelf", 2, 0)
    task = sim.task
    run_demo(sim, shifted(3, [-0.20, 0.0, -0.11]))  # stood on the table in front of the shelf
    assert not task.on_top_shelf(0) and not task.grasped()
    assert not sim.is_success()


def test_umbrella_held_in_the_stand_or_dropped_beside_it_is_not_a_success(sim):
    sim.reset_state("put_umbrella_in_umbrella_stand", 0, 0)
    task = sim.task
    release = keep_holding(sim, 5)
    assert task.in_stand() and task.grasped()
    assert not sim.is_success()
    assert sim.execute(release).success

    sim.reset_state("put_umbrella_in_umbrella_stand", 1, 0)
    task = sim.task
    stand_y = float(task.stand.get_root_pose().p[1])
    run_demo(sim, shifted(3, [0.0, -0.14 if stand_y > 0 else 0.14, 0.0]))
    assert not task.in_stand() and not task.grasped()
    assert not sim.is_success()
