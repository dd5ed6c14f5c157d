"""Task-specific checks of reach_and_drag, stack_cups, place_shape_in_shape_sorter, place_cups,
light_bulb_in and sweep_to_dustpan_of_size: a deliberately wrong outcome is not a success.

Uses the session-wide `sim` fixture (conftest.py).
"""

import pytest

pytest.importorskip("sapien")

from xicm.core.types import KeyAction  # noqa: E402


def run_demo_as(sim, variation: int) -> None:
    """Execute the scripted demonstrator as if `variation` were the episode's variation."""
    target = sim.task.variation
    sim.task.variation = variation
    try:
        for action in sim.task.demonstration():
            assert sim.execute(action).ok
    finally:
        sim.task.variation = target


def test_reach_and_drag_cube_on_the_wrong_target_is_not_a_success(sim):
    sim.reset_state("reach_and_drag", 3, 0)
    wrong = (sim.task.variation + 1) % 4
    run_demo_as(sim, wrong)
    assert sim.task.cube_on(wrong)
    assert not sim.is_success()


def test_stack_cups_on_the_wrong_cup_is_not_a_success(sim):
    sim.reset_state("stack_cups", 1, 0)
    wrong = (sim.task.variation + 1) % 3
    run_demo_as(sim, wrong)
    others = [i for i in range(3) if i != wrong]
    assert all(sim.task.inside(i, wrong) for i in others)  # a neat stack, on the wrong cup
    assert not sim.is_success()


def test_shape_sorter_wrong_shape_is_not_a_success(sim):
    sim.reset_state("place_shape_in_shape_sorter", 2, 0)
    wrong = (sim.task.variation + 1) % 4
    run_demo_as(sim, wrong)
    assert sim.task.in_sorter(wrong)
    assert not sim.is_success()


def test_light_bulb_in_needs_the_bulb_let_go_and_the_right_bulb(sim):
    sim.reset_state("light_bulb_in", 0, 0)
    bulb = sim.task.bulbs[sim.task.variation].per_scene_id
    demo = sim.task.demonstration()
    for _ in range(5):  # approach, grasp, lift, carry, lower the screw base into the socket
        inserted = next(demo)
        assert sim.execute(inserted).ok
    assert not inserted.gripper_open
    assert sim.task.in_lamp(sim.task.variation) and bulb in sim.task.grasped()
    assert not sim.is_success()  # in the lamp but still held
    assert sim.execute(KeyAction(inserted.position, inserted.quat_wxyz, True)).success  # let go
    # the other bulb in the lamp is no success either
    sim.reset_state("light_bulb_in", 0, 0)
    wrong = 1 - sim.task.variation
    run_demo_as(sim, wrong)
    assert sim.task.in_lamp(wrong)
    assert not sim.is_success()


def test_sweep_into_the_wrong_dustpan_is_not_a_success(sim):
    sim.reset_state("sweep_to_dustpan_of_size", 1, 0)
    wrong = 1 - sim.task.variation
    run_demo_as(sim, wrong)
    assert sim.task.dirt_in(wrong)
    assert not sim.is_success()


def test_place_cups_too_few_cups_is_not_a_success(sim):
    seed = next(s for s in range(50) if sim.reset_state("place_cups", s, 0) or sim.task.count >= 2)
    sim.reset_state("place_cups", seed, 0)
    asked = sim.task.count
    sim.task.count = asked - 1  # let the demonstrator hang one cup too few
    try:
        for action in sim.task.demonstration():
            assert sim.execute(action).ok
    finally:
        sim.task.count = asked
    assert sum(sim.task.hanging(i) for i in range(3)) == asked - 1
    assert not sim.is_success()
