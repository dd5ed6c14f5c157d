"""SAPIEN tasks that press a button, turn a knob or pull a plug (lamp_off, lamp_on, turn_oven_on,
take_usb_out_of_computer, unplug_charger): pressed, turned or pulled too little, or undone
again, is not a success; the success tests mean what their tasks say.

Most tests let the task's own scripted demonstrator produce the wrong outcome (by stopping it
early or changing one of its constants) and check that the success test says no.
"""

import numpy as np
import pytest
from task_demos import go, moved, paper_sim, paper_simulator, run_demo  # noqa: F401 (paper_sim: a fixture)

from xicm.plugins.simulators.sapien.tasks.unseen import lamp_off, turn_oven_on, unplug_charger


# ------------------------------------------------------------------ lamp_off, lamp_on
def _press(sim, task, depth: float) -> float:
    """Press the lamp button with the closed fingertips `depth` metres in, then come back up;
    returns how far the button went in."""
    root = task.lamp.get_root_pose()
    demo = list(task.demonstration())
    top = task.world_point(root, [lamp_off.BUTTON_X, 0, lamp_off.BASE_H + lamp_off.CAP_OUT])
    press = top + [0.0, 0.0, lamp_off.FINGERTIP - depth]
    go(sim, task.key(press + [0, 0, 0.08], demo[0].quat_wxyz, False))
    go(sim, task.key(press, demo[0].quat_wxyz, False))
    pressed = task.depth()
    go(sim, task.key(press + [0, 0, 0.08], demo[0].quat_wxyz, False))
    return pressed


@pytest.mark.parametrize("name", ["lamp_off", "lamp_on"])
def test_lamp_button_touched_but_not_pressed_enough_is_not_a_success(physics_sim, name):
    physics_sim.reset_state(name, 6, 0)
    task = physics_sim.task
    lit = task.lit
    pressed = _press(physics_sim, task, 0.0015)
    assert 0.0 < pressed < 0.003
    assert task.lit == lit and not physics_sim.is_success()
    _press(physics_sim, task, 0.006)  # a real press toggles the light
    assert task.lit != lit and physics_sim.is_success()


@pytest.mark.parametrize("name", ["lamp_off", "lamp_on"])
def test_lamp_pressed_twice_is_back_where_it_started(physics_sim, name):
    physics_sim.reset_state(name, 7, 0)
    task = physics_sim.task
    lit = task.lit
    assert lit == (name == "lamp_off")
    _press(physics_sim, task, 0.006)
    assert task.lit != lit and physics_sim.is_success()
    _press(physics_sim, task, 0.006)
    assert task.presses == 2 and task.lit == lit
    assert not physics_sim.is_success()


def test_lamp_light_shows_on_the_bulb(physics_sim):
    physics_sim.reset_state("lamp_on", 8, 0)
    task = physics_sim.task
    assert np.allclose(task.bulb_look.emission, 0.0)
    run_demo(physics_sim)
    assert physics_sim.is_success() and task.lit
    assert np.max(task.bulb_look.emission[:3]) > 0.5


@pytest.mark.parametrize("name", ["lamp_off", "lamp_on"])
def test_lamp_under_rlbench_scenes_counts_the_button_held_in_and_never_switches_back(name):
    """simulator.scenes: rlbench: RLBench's JointCondition (the button in by more than 3 mm now,
    not latched) and a bulb that never switches back; read after each key action here."""
    sim = paper_simulator(success_check="per_action")
    try:
        sim.reset_state(name, 7, 0)
        task = sim.task
        lit = task.lit
        above, press = task.demonstration()  # it ends pressing
        go(sim, above)
        go(sim, press)
        assert task.depth() > lamp_off.PRESSED and sim.is_success() and task.lit != lit
        go(sim, above)
        assert task.depth() < lamp_off.PRESSED and not sim.is_success()  # the spring lifted it: not latched
        assert task.lit != lit
        go(sim, press)  # ours would switch the light back and fail
        assert task.presses == 2 and task.lit != lit and sim.is_success()
    finally:
        sim.close()


def test_lamp_under_the_paper_settings_succeeds_at_the_press_with_its_arm_straight_back(paper_sim, physics_sim):
    for seed in range(3):
        paper_sim.reset_state("lamp_on", seed, 0)
        assert paper_sim.task.arm_yaw == 0.0
    physics_sim.reset_state("lamp_on", 0, 0)
    assert physics_sim.task.arm_yaw != 0.0  # ours draws it
    task = paper_sim.task
    above, press = task.demonstration()
    go(paper_sim, above)
    outcome = paper_sim.execute(press)
    assert outcome.success and task.lit  # the move stopped pressed in (per_frame)


# ------------------------------------------------------------------ turn_oven_on
def test_oven_knobs_start_at_one_angle_under_rlbench_scenes_only(paper_sim, physics_sim):
    for seed in range(2):
        paper_sim.reset_state("turn_oven_on", seed, 0)
        assert np.allclose(paper_sim.task.start_q, 0.0) and np.allclose(paper_sim.task.oven.get_qpos(), 0.0, atol=1e-3)
        physics_sim.reset_state("turn_oven_on", seed, 0)
        assert np.all(np.abs(physics_sim.task.start_q) > 1e-3)  # ours: each drawn in [-30, 30] degrees
    run_demo(paper_sim)
    assert paper_sim.is_success()


def test_turning_the_oven_knob_only_a_little_is_not_a_success(physics_sim, monkeypatch):
    monkeypatch.setattr(turn_oven_on, "TURN", np.deg2rad(45.0))
    physics_sim.reset_state("turn_oven_on", 1, 0)
    run_demo(physics_sim)
    assert 0.5 < physics_sim.task.turned()[0] < 1.0
    assert not physics_sim.is_success()


# ------------------------------------------------------------------ take_usb_out_of_computer
def test_usb_stick_pulled_out_but_still_held_is_not_a_success(physics_sim):
    physics_sim.reset_state("take_usb_out_of_computer", 2, 0)
    task = physics_sim.task
    for action in task.demonstration():
        if action.gripper_open and not physics_sim.robot.gripper_open:
            # the demonstrator is about to let go: the stick is out of the port, still in the hand
            assert not task.plug_in_port() and task.stick.per_scene_id in task.grasped()
            assert not physics_sim.is_success()
            assert physics_sim.execute(action).success  # putting it down and letting go completes the task
            break
        go(physics_sim, action)
    else:
        pytest.fail("the demonstrator never let go of the stick")


def test_letting_go_of_the_usb_stick_without_pulling_is_not_a_success(physics_sim):
    physics_sim.reset_state("take_usb_out_of_computer", 3, 0)
    task = physics_sim.task
    actions = task.demonstration()
    approach, grasp = next(actions), next(actions)
    go(physics_sim, approach)
    go(physics_sim, grasp)
    assert task.grasped()
    go(physics_sim, moved(grasp, gripper_open=True))  # open again where it gripped
    go(physics_sim, approach)
    assert task.plug_in_port() and not task.grasped()
    assert not physics_sim.is_success()


# ------------------------------------------------------------------ unplug_charger
def test_charger_pulled_only_a_little_is_not_unplugged(physics_sim, monkeypatch):
    monkeypatch.setattr(unplug_charger, "PULL", 0.008)  # pins are 19 mm long
    physics_sim.reset_state("unplug_charger", 4, 0)
    run_demo(physics_sim)
    task = physics_sim.task
    assert task.pins_in_socket() and task.grasped()
    assert not physics_sim.is_success()


def test_unplugged_charger_may_stay_in_the_hand(physics_sim):
    physics_sim.reset_state("unplug_charger", 5, 0)
    assert physics_sim.task.pins_in_socket()
    run_demo(physics_sim)
    task = physics_sim.task
    assert task.charger.per_scene_id in task.grasped()  # holding it is allowed
    assert physics_sim.is_success()
