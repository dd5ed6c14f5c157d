"""SAPIEN tasks that handle a tool (scoop_with_spatula, beat_the_buzz, water_plants): plausible
wrong uses are not a success. (Their wrong-target and let-go checks, and those of
reach_and_drag, slide_block_to_color_target and sweep_to_dustpan_of_size, are in
test_tasks_wrong_target.py and test_tasks_pick_and_place.py.)

Each test drives the task's own scripted demonstrator and changes one key action into the
mistake. scoop_with_spatula's key poses: 0 above the handle, 1 grasp, 2 lift, 3 above the start
of the push, 4 blade on the table, 5 blade pushed under the cube, 6 lift.
"""

import numpy as np
import sapien
from task_demos import go, moved, paper_sim, run_demo  # noqa: F401 (paper_sim: a fixture)

from xicm.core.contracts.types import KeyAction
from xicm.plugins.simulators.sapien.scene import TABLE_TOP_Z


# ------------------------------------------------------------------ scoop_with_spatula
def test_scoop_cube_is_2_cm_under_rlbench_scenes_and_still_scooped(paper_sim, physics_sim):
    """RoboVerse's export of RLBench's task makes the cube 2 cm (ours: 4 cm): its resting height
    shows the collision shape's size."""
    for sim, side in ((physics_sim, 0.04), (paper_sim, 0.02)):
        sim.reset_state("scoop_with_spatula", 1, 0)
        assert abs(float(sim.task.cube.pose.p[2]) - TABLE_TOP_Z - side / 2) < 1e-3
    run_demo(paper_sim)
    assert paper_sim.is_success()


def spatula_held(task) -> bool:
    return task.spatula.per_scene_id in task.grasped()


def test_scoop_demo_success_needs_every_part(physics_sim):
    physics_sim.reset_state("scoop_with_spatula", 0, 0)
    task = physics_sim.task
    for i, action in enumerate(task.demonstration()):
        go(physics_sim, action)
        if i == 5:  # the blade is under the cube, still on the table: scooped but not lifted
            assert task.cube_on_blade() and spatula_held(task)
            assert not physics_sim.is_success()
    assert float(task.cube.pose.p[2]) - 0.02 > TABLE_TOP_Z + 0.05
    assert task.cube_on_blade() and spatula_held(task)
    assert physics_sim.is_success()


def test_scoop_cube_pushed_but_not_scooped_is_not_a_success(physics_sim):
    physics_sim.reset_state("scoop_with_spatula", 1, 0)
    task = physics_sim.task
    for i, action in enumerate(task.demonstration()):
        if i == 5:  # the push stops 3 cm short: the blade is only under the cube's front edge
            back = -0.03 * task.push_dir
            action = moved(action, (back[0], back[1], 0.0))
        go(physics_sim, action)
    assert spatula_held(task)
    assert float(task.spatula.pose.p[2]) > TABLE_TOP_Z + 0.08  # the spatula is up ...
    assert float(task.cube.pose.p[2]) < TABLE_TOP_Z + 0.02 + 0.05  # ... the cube slid off it
    assert not task.cube_on_blade()
    assert not physics_sim.is_success()


def test_scoop_spatula_lifted_without_the_cube_is_not_a_success(physics_sim):
    physics_sim.reset_state("scoop_with_spatula", 2, 0)
    task = physics_sim.task
    start = None
    for i, action in enumerate(task.demonstration()):
        if i == 4:
            start = action
        if i == 5:  # no push: the blade stops in front of the cube
            action = start
        if i == 6:
            action = moved(start, (0.0, 0.0, 0.10))
        go(physics_sim, action)
    assert spatula_held(task)
    assert float(task.spatula.pose.p[2]) > TABLE_TOP_Z + 0.08  # the spatula is up ...
    assert float(task.cube.pose.p[2]) < TABLE_TOP_Z + 0.03  # ... the cube is not
    assert not physics_sim.is_success()


def test_scoop_cube_on_the_spatula_but_spatula_let_go_is_not_a_success(physics_sim):
    physics_sim.reset_state("scoop_with_spatula", 3, 0)
    task = physics_sim.task
    last = None
    for action in task.demonstration():
        go(physics_sim, action)
        last = action
    assert physics_sim.is_success()
    physics_sim.execute(moved(last, gripper_open=True))  # let go of the lifted spatula
    assert not spatula_held(task)
    assert not physics_sim.is_success()


def test_scoop_cube_on_the_blade_on_the_table_released_is_not_a_success(physics_sim):
    physics_sim.reset_state("scoop_with_spatula", 4, 0)
    task = physics_sim.task
    actions = task.demonstration()
    for _, action in zip(range(6), actions):  # up to the blade pushed under the cube
        go(physics_sim, action)
    physics_sim.execute(moved(action, gripper_open=True))  # instead of lifting: let go ...
    physics_sim.execute(moved(action, (0.0, 0.0, 0.10), gripper_open=True))  # ... and move the hand up
    assert task.cube_on_blade() and not spatula_held(task)
    assert np.isclose(float(task.spatula.pose.p[2]), TABLE_TOP_Z, atol=0.01)
    assert not physics_sim.is_success()


# ------------------------------------------------------------------ beat_the_buzz
def test_beat_the_buzz_a_step_ending_on_the_wire_fails_for_good(physics_sim):
    physics_sim.reset_state("beat_the_buzz", 0, 0)
    task = physics_sim.task
    for i, action in enumerate(task.demonstration()):
        if i == 3:  # the carry along the wire, 3 cm too high: the ring's bottom bar drags on the wire
            # (3 cm too low jams the foot on the end rest once the grasp is rigid, simulator.grasp: attach)
            high = moved(action, (0.0, 0.0, 0.03))
            physics_sim.execute(high)
            assert task.touched
            physics_sim.execute(action)  # back on the right line, then finish the demonstration
            continue
        physics_sim.execute(action)
    assert task.at_end() and not task.grasped()
    assert not physics_sim.is_success()


def test_beat_the_buzz_a_touch_gone_by_the_end_of_the_step_is_not_a_failure(physics_sim):
    """RLBench reads the wire's fail sensor only after each step, as the end of each key action here."""
    import sapien

    physics_sim.reset_state("beat_the_buzz", 0, 0)
    task = physics_sim.task
    for i, action in enumerate(task.demonstration()):
        if i == 3:  # the carry 3 cm too high, as a move inside a step: the ring drags on the wire ...
            high = moved(action, (0.0, 0.0, 0.03))
            physics_sim.controller.move_to(sapien.Pose(np.asarray(high.position), np.asarray(high.quat_wxyz)))
            assert task.wand_touches_wire() and not task.touched
            physics_sim.execute(action)  # ... and the step ends back on the right line, clear of the wire
            assert not task.touched
            continue
        physics_sim.execute(action)
    assert physics_sim.is_success()


def test_beat_the_buzz_wand_left_on_the_start_rest_is_not_a_success(physics_sim):
    physics_sim.reset_state("beat_the_buzz", 2, 0)
    actions = physics_sim.task.demonstration()  # key poses depend on the state as it goes: run it lazily
    lifted = None
    for _, action in zip(range(3), actions):  # grasp, lift the ring onto the wire axis ...
        physics_sim.execute(action)
        lifted = action
    physics_sim.execute(moved(lifted, (0.0, 0.0, -0.01), gripper_open=True))  # ... and put it back
    assert not physics_sim.task.touched and not physics_sim.task.grasped()
    assert not physics_sim.is_success()


# ------------------------------------------------------------------ water_plants
def test_water_plants_can_held_over_the_pot_untipped_is_not_a_success(physics_sim):
    physics_sim.reset_state("water_plants", 0, 0)
    task = physics_sim.task
    for i, action in enumerate(task.demonstration()):
        if i == 4:  # the tipping: stay upright at the pouring position instead
            break
        go(physics_sim, action)
    for _ in range(20):
        physics_sim.controller.step_frame()
    assert not task.poured and task.drops_in_pot() == 0 and task.grasped()  # the tip is not at the pour point
    assert not physics_sim.is_success()


def test_water_plants_poured_beside_the_pot_is_not_a_success(physics_sim):
    physics_sim.reset_state("water_plants", 1, 0)
    task = physics_sim.task
    for i, action in enumerate(task.demonstration()):
        # pour 15 cm towards the robot of where the demonstrator would: the water misses the pot
        physics_sim.execute(moved(action, (-0.15, 0.0, 0.0)) if i >= 3 else action)
    for _ in range(20):
        physics_sim.controller.step_frame()
    assert not task.poured and task.drops_in_pot() == 0  # the tip never reached the pour point
    assert not physics_sim.is_success()


def test_water_plants_one_drop_outside_the_pot_is_not_a_success(physics_sim):
    """RLBench counts all of its drops in the pot's sensor."""
    physics_sim.reset_state("water_plants", 2, 0)
    task = physics_sim.task
    for action in task.demonstration():
        go(physics_sim, action)
    assert task.poured and task.drops_in_pot() == 5 and physics_sim.is_success()
    pot = task.pot.pose.p
    task.drops[0].set_pose(sapien.Pose([float(pot[0]), float(pot[1]) - 0.12, TABLE_TOP_Z + 0.003]))  # on the table
    assert task.drops_in_pot() == 4
    assert not physics_sim.is_success()


def drop_can_above_the_pot(sim, seed):
    """Take the can and let go of it 25 cm above the plant (what copying a pick-and-place demo does)."""
    sim.reset_state("water_plants", seed, 0)
    task = sim.task
    actions = list(task.demonstration())[:3]  # above the handle, grasp, lift
    for action in actions:
        go(sim, action)
    pot = task.pot.pose.p
    above = KeyAction((float(pot[0]), float(pot[1]), float(pot[2]) + 0.25), actions[-1].quat_wxyz, False)
    go(sim, above)
    sim.execute(moved(above, gripper_open=True))  # let go
    for _ in range(30):
        sim.controller.step_frame()
    assert not task.grasped()
    return task


def test_water_plants_upright_can_carried_through_the_pour_point_and_dropped_is_a_success_as_upstream(physics_sim):
    """RLBench spawns its drops when the spout's head first meets the pour point and requires
    neither tipping nor a grasp: here the upright can's tip passes the pour point on the way over
    the plant, the drops fall into the pot, and the can is let go of."""
    task = drop_can_above_the_pot(physics_sim, 6)
    assert task.poured and task.drops_in_pot() == 5 and physics_sim.is_success()


def test_water_plants_can_dropped_with_its_tip_off_the_pour_point_is_not_a_success(physics_sim):
    """The can rests on the pot, its tip 14 cm off the pot's axis: no drops (upstream's earlier
    clause, the can itself in the pot's sensor, is not followed: docs/reference/protocol-and-fidelity.md)."""
    task = drop_can_above_the_pot(physics_sim, 0)
    assert not task.poured and task.drops_in_pot() == 0
    assert not physics_sim.is_success()
