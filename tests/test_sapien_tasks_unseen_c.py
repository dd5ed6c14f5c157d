"""Task-specific checks of the unseen SAPIEN tasks turn_oven_on, take_usb_out_of_computer,
unplug_charger, take_lid_off_saucepan and take_plate_off_colored_dish_rack: plausible wrong
actions are not a success, and the success tests mean what their tasks say.

Most tests let the task's own scripted demonstrator produce the wrong outcome (by stopping it
early, changing one of its constants or pointing it at the wrong object) and check that the
success test says no.
"""

import numpy as np
import pytest

pytest.importorskip("sapien")

from xicm.core.types import KeyAction  # noqa: E402
from xicm.plugins.simulators.sapien.tasks.unseen import (  # noqa: E402
    take_lid_off_saucepan,
    turn_oven_on,
    unplug_charger,
)


def run_demo(sim) -> None:
    """Execute the current task's demonstration (its key poses depend on the state as it goes)."""
    for action in sim.task.demonstration():
        assert sim.execute(action).ok


def with_gripper(action: KeyAction, gripper_open: bool) -> KeyAction:
    return KeyAction(action.position, action.quat_wxyz, gripper_open)


# ------------------------------------------------------------------ turn_oven_on
def test_turning_the_right_knob_does_not_turn_the_oven_on(sim):
    sim.reset_state("turn_oven_on", 0, 0)
    task = sim.task
    for action in task.demonstration(index=1):  # the demonstrator, pointed at the right knob
        assert sim.execute(action).ok
    turned = task.turned()
    assert turned[1] > 1.6 and turned[0] < 0.1
    assert not sim.is_success()


def test_turning_the_oven_knob_only_a_little_is_not_a_success(sim, monkeypatch):
    monkeypatch.setattr(turn_oven_on, "TURN", np.deg2rad(45.0))
    sim.reset_state("turn_oven_on", 1, 0)
    run_demo(sim)
    assert 0.5 < sim.task.turned()[0] < 1.0
    assert not sim.is_success()


# ------------------------------------------------------------------ take_usb_out_of_computer
def test_usb_stick_pulled_out_but_still_held_is_not_a_success(sim):
    sim.reset_state("take_usb_out_of_computer", 2, 0)
    task = sim.task
    for action in task.demonstration():
        if action.gripper_open and not sim.robot.gripper_open:
            # the demonstrator is about to let go: the stick is out of the port, still in the hand
            assert not task.plug_in_port() and task.stick.per_scene_id in task.grasped()
            assert not sim.is_success()
            assert sim.execute(action).success  # putting it down and letting go completes the task
            break
        assert sim.execute(action).ok
    else:
        pytest.fail("the demonstrator never let go of the stick")


def test_letting_go_of_the_usb_stick_without_pulling_is_not_a_success(sim):
    sim.reset_state("take_usb_out_of_computer", 3, 0)
    task = sim.task
    actions = task.demonstration()
    approach, grasp = next(actions), next(actions)
    assert sim.execute(approach).ok and sim.execute(grasp).ok
    assert task.grasped()
    assert sim.execute(with_gripper(grasp, True)).ok  # open again where it gripped
    assert sim.execute(approach).ok
    assert task.plug_in_port() and not task.grasped()
    assert not sim.is_success()


# ------------------------------------------------------------------ unplug_charger
def test_charger_pulled_only_a_little_is_not_unplugged(sim, monkeypatch):
    monkeypatch.setattr(unplug_charger, "PULL", 0.008)  # pins are 19 mm long
    sim.reset_state("unplug_charger", 4, 0)
    run_demo(sim)
    task = sim.task
    assert task.pins_in_socket() and task.grasped()
    assert not sim.is_success()


def test_unplugged_charger_may_stay_in_the_hand(sim):
    sim.reset_state("unplug_charger", 5, 0)
    assert sim.task.pins_in_socket()
    run_demo(sim)
    task = sim.task
    assert task.charger.per_scene_id in task.grasped()  # holding it is allowed
    assert sim.is_success()


# ------------------------------------------------------------------ take_lid_off_saucepan
def test_saucepan_lid_lifted_then_dropped_is_not_a_success(sim):
    sim.reset_state("take_lid_off_saucepan", 6, 0)
    task = sim.task
    actions = list(task.demonstration())
    for action in actions:
        assert sim.execute(action).ok
    assert sim.is_success()
    assert sim.execute(with_gripper(actions[-1], True)).ok  # let go of the lid above the pan
    for _ in range(20):
        sim.controller.step_frame()
    assert not task.grasped() and not task.lid_lifted()
    assert not sim.is_success()


def test_saucepan_lid_raised_only_a_little_is_not_a_success(sim, monkeypatch):
    monkeypatch.setattr(take_lid_off_saucepan, "LIFT", 0.03)
    sim.reset_state("take_lid_off_saucepan", 7, 0)
    run_demo(sim)
    task = sim.task
    assert task.lid.per_scene_id in task.grasped() and not task.lid_lifted()
    assert not sim.is_success()


# ------------------------------------------------------------------ take_plate_off_colored_dish_rack
def test_plate_held_at_the_table_is_not_a_success(sim):
    sim.reset_state("take_plate_off_colored_dish_rack", 8, 0)
    task = sim.task
    for action in task.demonstration():
        if action.gripper_open and not sim.robot.gripper_open:
            # go down to the table but keep holding the plate
            assert sim.execute(with_gripper(action, False)).ok
            assert task.off_rack() and task.on_table() and task.grasped()
            assert not sim.is_success()
            assert sim.execute(action).success  # letting go completes the task
            break
        assert sim.execute(action).ok
    else:
        pytest.fail("the demonstrator never let go of the plate")


def test_plate_lifted_and_put_back_in_the_rack_is_not_a_success(sim):
    sim.reset_state("take_plate_off_colored_dish_rack", 9, 0)
    task = sim.task
    actions = task.demonstration()
    approach, grasp, lift = next(actions), next(actions), next(actions)
    for action in (approach, grasp, lift):
        assert sim.execute(action).ok
    assert task.grasped()
    assert sim.execute(with_gripper(grasp, True)).ok  # back down into the slot, let go
    assert sim.execute(approach).ok
    assert not task.off_rack() and not task.grasped()
    assert not sim.is_success()


def test_plate_starts_in_the_black_slot(sim):
    for seed in range(3):
        sim.reset_state("take_plate_off_colored_dish_rack", seed, 0)
        task = sim.task
        plate = np.asarray(task.plate.pose.p)
        black = np.asarray(task.pillars["black"].pose.p)
        others = [np.asarray(task.pillars[c].pose.p) for c in ("red", "purple")]
        assert np.linalg.norm(plate[:2] - black[:2]) < 0.01
        assert all(np.linalg.norm(plate[:2] - o[:2]) > 0.04 for o in others)
