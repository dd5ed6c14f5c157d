"""Task-specific checks of the unseen level-2 SAPIEN task scoop_with_spatula: plausible wrong
actions are not a success.

Each test drives the task's own scripted demonstrator (key poses: 0 above the handle, 1 grasp,
2 lift, 3 above the start of the push, 4 blade on the table, 5 blade pushed under the cube,
6 lift) and changes one key action into the mistake.
"""

import dataclasses

import numpy as np
import pytest

pytest.importorskip("sapien")

TASK = "scoop_with_spatula"
TABLE_TOP_Z = 0.75


def moved(action, dxyz=(0.0, 0.0, 0.0), gripper_open=None):
    """The key action shifted by dxyz (metres), optionally with another gripper state."""
    position = tuple(float(p + d) for p, d in zip(action.position, dxyz))
    grip = action.gripper_open if gripper_open is None else gripper_open
    return dataclasses.replace(action, position=position, gripper_open=grip)


def spatula_held(task) -> bool:
    return task.spatula.per_scene_id in task.grasped()


def test_scoop_demo_success_needs_every_part(sim):
    sim.reset_state(TASK, 0, 0)
    task = sim.task
    for i, action in enumerate(task.demonstration()):
        assert sim.execute(action).ok
        if i == 5:  # the blade is under the cube, still on the table: scooped but not lifted
            assert task.cube_on_blade() and spatula_held(task)
            assert not sim.is_success()
    assert float(task.cube.pose.p[2]) - 0.02 > TABLE_TOP_Z + 0.05
    assert task.cube_on_blade() and spatula_held(task)
    assert sim.is_success()


def test_scoop_cube_pushed_but_not_scooped_is_not_a_success(sim):
    sim.reset_state(TASK, 1, 0)
    task = sim.task
    for i, action in enumerate(task.demonstration()):
        if i == 5:  # the push stops 3 cm short: the blade is only under the cube's front edge
            back = -0.03 * task.push_dir
            action = moved(action, (back[0], back[1], 0.0))
        assert sim.execute(action).ok
    assert spatula_held(task)
    assert float(task.spatula.pose.p[2]) > TABLE_TOP_Z + 0.08  # the spatula is up ...
    assert float(task.cube.pose.p[2]) < TABLE_TOP_Z + 0.02 + 0.05  # ... the cube slid off it
    assert not task.cube_on_blade()
    assert not sim.is_success()


def test_scoop_spatula_lifted_without_the_cube_is_not_a_success(sim):
    sim.reset_state(TASK, 2, 0)
    task = sim.task
    start = None
    for i, action in enumerate(task.demonstration()):
        if i == 4:
            start = action
        if i == 5:  # no push: the blade stops in front of the cube
            action = start
        if i == 6:
            action = moved(start, (0.0, 0.0, 0.10))
        assert sim.execute(action).ok
    assert spatula_held(task)
    assert float(task.spatula.pose.p[2]) > TABLE_TOP_Z + 0.08  # the spatula is up ...
    assert float(task.cube.pose.p[2]) < TABLE_TOP_Z + 0.03  # ... the cube is not
    assert not sim.is_success()


def test_scoop_cube_on_the_spatula_but_spatula_let_go_is_not_a_success(sim):
    sim.reset_state(TASK, 3, 0)
    task = sim.task
    last = None
    for action in task.demonstration():
        assert sim.execute(action).ok
        last = action
    assert sim.is_success()
    sim.execute(moved(last, gripper_open=True))  # let go of the lifted spatula
    assert not spatula_held(task)
    assert not sim.is_success()


def test_scoop_cube_on_the_blade_on_the_table_released_is_not_a_success(sim):
    sim.reset_state(TASK, 4, 0)
    task = sim.task
    actions = task.demonstration()
    for _, action in zip(range(6), actions):  # up to the blade pushed under the cube
        assert sim.execute(action).ok
    sim.execute(moved(action, gripper_open=True))  # instead of lifting: let go ...
    sim.execute(moved(action, (0.0, 0.0, 0.10), gripper_open=True))  # ... and move the hand up
    assert task.cube_on_blade() and not spatula_held(task)
    assert np.isclose(float(task.spatula.pose.p[2]), TABLE_TOP_Z, atol=0.01)
    assert not sim.is_success()
