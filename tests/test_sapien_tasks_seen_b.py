"""Task-specific checks of the seen SAPIEN tasks meat_off_grill, put_money_in_safe,
insert_onto_square_peg, put_groceries_in_cupboard and place_wine_at_rack_location: a
deliberately wrong outcome is not a success.

Each test lets the task's own scripted demonstrator produce the wrong outcome (by pointing it
at the wrong object, or by not letting go) and checks that the success test says no.
"""

import pytest

pytest.importorskip("sapien")

from xicm.core.types import KeyAction


def run_demo(sim) -> None:
    """Execute the current task's demonstration (its key poses depend on the state as it goes)."""
    for action in sim.task.demonstration():
        assert sim.execute(action).ok


def release_while_holding(sim) -> None:
    """Run the demonstration up to its release, go to the release pose but keep holding;
    check that this is not a success and that letting go then is."""
    task = sim.task
    for action in task.demonstration():
        if action.gripper_open and not sim.robot.gripper_open:
            assert sim.execute(KeyAction(action.position, action.quat_wxyz, False)).ok
            assert task.grasped()
            assert not sim.is_success()
            assert sim.execute(action).success  # letting go completes the task
            return
        assert sim.execute(action).ok
    pytest.fail("the demonstrator never let go")


def test_meat_off_grill_wrong_meat_or_meat_still_held_is_not_a_success(sim):
    sim.reset_state("meat_off_grill", 0, 0)
    task = sim.task
    target = task.variation
    wrong = 1 - target
    task.variation = wrong  # take the other piece off the grill
    run_demo(sim)
    task.variation = target
    assert task.off_grill(wrong) and not task.off_grill(target) and not task.grasped()
    assert not sim.is_success()

    sim.reset_state("meat_off_grill", 1, 0)
    release_while_holding(sim)
    assert sim.task.off_grill(sim.task.variation)


def test_put_money_in_safe_wrong_shelf_or_money_still_held_is_not_a_success(sim):
    sim.reset_state("put_money_in_safe", 0, 0)
    task = sim.task
    target = task.variation
    wrong = (target + 1) % 3
    task.variation = wrong  # put the money on another shelf
    run_demo(sim)
    task.variation = target
    assert task.shelf_of_money() == wrong and not task.grasped()
    assert not sim.is_success()

    sim.reset_state("put_money_in_safe", 2, 0)
    release_while_holding(sim)
    assert sim.task.shelf_of_money() == sim.task.variation


def test_insert_onto_square_peg_wrong_spoke_is_not_a_success(sim):
    sim.reset_state("insert_onto_square_peg", 0, 0)
    task = sim.task
    target = task.target
    wrong = (target + 1) % 3
    task.target = wrong  # drop the ring over another spoke
    run_demo(sim)
    task.target = target
    assert task.spoke_of_ring() == wrong
    assert not sim.is_success()


def test_put_groceries_in_cupboard_wrong_item_or_item_still_held_is_not_a_success(sim):
    sim.reset_state("put_groceries_in_cupboard", 0, 0)
    task = sim.task
    target = task.variation
    wrong = (target + 1) % len(task.items)
    task.variation = wrong  # put another item in the cupboard
    run_demo(sim)
    task.variation = target
    assert task.in_cupboard(wrong) and not task.in_cupboard(target) and not task.grasped()
    assert not sim.is_success()

    sim.reset_state("put_groceries_in_cupboard", 1, 0)
    release_while_holding(sim)
    assert sim.task.in_cupboard(sim.task.variation)


def test_place_wine_at_rack_location_wrong_slot_or_bottle_still_held_is_not_a_success(sim):
    sim.reset_state("place_wine_at_rack_location", 0, 0)
    task = sim.task
    target = task.variation
    wrong = (target + 1) % 3
    task.variation = wrong  # lay the bottle in another slot
    run_demo(sim)
    task.variation = target
    assert task.slot_of_bottle() == wrong and not task.grasped()
    assert not sim.is_success()

    sim.reset_state("place_wine_at_rack_location", 1, 0)
    release_while_holding(sim)
    assert sim.task.slot_of_bottle() == sim.task.variation
