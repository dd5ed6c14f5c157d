"""Task-specific checks of the seen SAPIEN tasks close_jar, stack_blocks, put_item_in_drawer,
turn_tap and slide_block_to_color_target: a deliberately wrong outcome is not a success.

Each test lets the task's own scripted demonstrator produce the wrong outcome (by pointing it
at the wrong object for a while) and checks that the success test says no.
"""

import pytest

pytest.importorskip("sapien")

from xicm.core.types import KeyAction  # noqa: E402


def run_demo(sim) -> None:
    """Execute the current task's demonstration (its key poses depend on the state as it goes)."""
    for action in sim.task.demonstration():
        assert sim.execute(action).ok


def test_close_jar_wrong_jar_or_lid_still_held_is_not_a_success(sim):
    sim.reset_state("close_jar", 0, 0)
    task = sim.task
    target, other = task.jars
    task.target_jar = other  # close the distractor instead
    run_demo(sim)
    task.target_jar = target
    assert task.lid_on(other) and not task.grasped()
    assert not sim.is_success()

    sim.reset_state("close_jar", 1, 0)
    task = sim.task
    actions = task.demonstration()
    for action in actions:
        if action.gripper_open and not sim.robot.gripper_open:
            # the release over the jar: go there but keep holding the lid
            assert sim.execute(KeyAction(action.position, action.quat_wxyz, False)).ok
            assert task.lid_on(task.target_jar) and task.grasped()
            assert not sim.is_success()
            assert sim.execute(action).success  # letting go completes the task
            break
        assert sim.execute(action).ok
    else:
        pytest.fail("the demonstrator never released the lid")


def test_stack_blocks_too_few_blocks_is_not_a_success(sim):
    for seed in range(20):
        sim.reset_state("stack_blocks", seed, 0)
        if sim.task.count >= 3:
            break
    task = sim.task
    count = task.count
    task.count = count - 1  # the demonstrator stacks one block too few
    run_demo(sim)
    task.count = count
    assert task.stacked() == count - 1 and not task.grasped()
    assert not sim.is_success()


def test_put_item_in_the_wrong_drawer_is_not_a_success(sim):
    sim.reset_state("put_item_in_drawer", 2, 0)
    task = sim.task
    target = task.variation
    wrong = (target + 1) % 3
    task.variation = wrong
    run_demo(sim)
    task.variation = target
    assert task.in_drawer(wrong) and not task.in_drawer(target)
    assert not sim.is_success()


def test_turning_the_wrong_tap_is_not_a_success(sim):
    sim.reset_state("turn_tap", 3, 0)
    task = sim.task
    target = task.variation
    task.variation = 1 - target
    run_demo(sim)
    task.variation = target
    turned = task.turned()
    assert turned[1 - target] > 1.6 and turned[target] < 0.2
    assert not sim.is_success()


def test_sliding_to_the_wrong_target_is_not_a_success(sim):
    sim.reset_state("slide_block_to_color_target", 4, 0)
    task = sim.task
    target = task.variation
    wrong = (target + 2) % 4
    task.variation = wrong
    run_demo(sim)
    task.variation = target
    assert task.on_target(wrong) and not task.on_target(target)
    assert not sim.is_success()
