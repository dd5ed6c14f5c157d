"""The SAPIEN task straighten_rope (a deformable rope, level 2): plausible wrong outcomes are
not a success.

Each test drives the task's own scripted demonstrator and stops it early or changes one key
action into the mistake (only the head placed, the tail set down short of its zone, the tail
still held up over its zone, the ends swapped).
"""

import numpy as np
import pytest
from task_demos import go, moved, paper_sim, run_demo  # noqa: F401 (paper_sim: a fixture)

TASK = "straighten_rope"


def in_zones(task):
    return task.end_in_zone(task.head, task.zones[0]), task.end_in_zone(task.tail, task.zones[1])


def releases(actions):
    """Indices of the key actions that open a closed gripper."""
    out, closed = [], False
    for i, a in enumerate(actions):
        if a.gripper_open and closed:
            out.append(i)
        closed = not a.gripper_open
    return out


def test_straighten_rope_only_the_head_placed_is_not_a_success(physics_sim):
    physics_sim.reset_state(TASK, 0, 0)
    task = physics_sim.task
    for action in task.demonstration():
        go(physics_sim, action)
        if not task.grasped() and in_zones(task)[0]:  # the head lies in its zone, let go
            break
    assert in_zones(task) == (True, False)
    assert not physics_sim.is_success()


def test_straighten_rope_tail_set_down_short_of_its_zone_is_not_a_success(physics_sim):
    physics_sim.reset_state(TASK, 2, 0)  # a seed whose tail still has to swing round after the pull
    task = physics_sim.task
    seen = []
    for action in task.demonstration():
        seen.append(action)
        if len(releases(seen)) == 1 and not action.gripper_open and not physics_sim.robot.gripper_open:
            # the tail is held and pulled out radially: put it down right there, rope still bent
            go(physics_sim, action)
            assert physics_sim.execute(moved(action, (0.0, 0.0, -0.02), gripper_open=True)).ok
            break
        go(physics_sim, action)
    assert not task.grasped()
    assert in_zones(task) == (True, False)
    assert not physics_sim.is_success()


def test_straighten_rope_tail_held_up_over_its_zone_is_not_a_success(physics_sim):
    physics_sim.reset_state(TASK, 1, 0)
    task = physics_sim.task
    seen = []
    for action in task.demonstration():
        seen.append(action)
        if len(releases(seen)) == 2:  # the tail's release at the table: stay 2 cm up, closed
            assert physics_sim.execute(moved(action, (0.0, 0.0, 0.02), gripper_open=False)).ok
            assert task.grasped()
            tail, zone = np.asarray(task.tail.entity.pose.p), np.asarray(task.zones[1].pose.p)
            assert np.linalg.norm(tail[:2] - zone[:2]) < 0.02  # right over the zone, but lifted
            assert not physics_sim.is_success()
            assert physics_sim.execute(action).success  # setting it down completes the task
            return
        go(physics_sim, action)
    pytest.fail("the demonstrator never released the tail")


def test_straighten_rope_ends_swapped_is_not_a_success(physics_sim):
    # the rope laid straight by the demonstrator, then the zones exchanged: each end now lies in
    # the other end's zone. (Driving the demonstrator into a swapped layout instead depended on
    # the rope's chaotic physics: a seed that managed it alone failed after other tests ran.)
    for seed in range(5):
        physics_sim.reset_state(TASK, seed, 0)
        run_demo(physics_sim)
        if physics_sim.is_success():
            break
    else:
        pytest.fail("the demonstrator straightened the rope on none of 5 seeds")
    task = physics_sim.task
    head_zone, tail_zone = (z.pose for z in task.zones)
    task.zones[0].set_pose(tail_zone)
    task.zones[1].set_pose(head_zone)
    assert task.end_in_zone(task.head, task.zones[1]) and task.end_in_zone(task.tail, task.zones[0])
    assert in_zones(task) == (False, False)
    assert not physics_sim.is_success()


def test_straighten_rope_starts_bent_with_both_ends_outside_their_zones(physics_sim):
    for seed in range(5):
        physics_sim.reset_state(TASK, seed, 0)
        task = physics_sim.task
        assert in_zones(task) == (False, False)
        head, tail = (np.asarray(e.entity.pose.p) for e in (task.head, task.tail))
        assert np.linalg.norm(head - tail) < 0.30  # a curve: shorter than the 32 cm rope
        assert abs(head[2] - tail[2]) < 1e-3  # lying flat on the table


def _layout(sim, seed: int) -> np.ndarray:
    """The distances between head, tail and the two zone centres (on the table) of a scene."""
    sim.reset_state(TASK, seed, 0)
    task = sim.task
    points = [np.asarray(e.entity.pose.p[:2]) for e in (task.head, task.tail)]
    points += [np.asarray(z.pose.p[:2]) for z in task.zones]
    return np.array([np.linalg.norm(a - b) for i, a in enumerate(points) for b in points[i + 1:]])


def test_straighten_rope_under_rlbench_scenes_keeps_one_rope_and_zone_layout(paper_sim, physics_sim):
    """RLBench's rope and zones are fixed by its scene (only the base is placed); ours are drawn."""
    first = _layout(paper_sim, 0)
    yaws = set()
    for seed in (1, 2):
        assert np.allclose(_layout(paper_sim, seed), first, atol=0.005)
        yaws.add(round(paper_sim.task.axis, 2))
    assert len(yaws) == 2  # placed and turned anew
    assert not np.allclose(_layout(physics_sim, 1), _layout(physics_sim, 2), atol=0.01)
    run_demo(paper_sim)
    assert paper_sim.is_success()


def test_a_draw_whose_rope_diverges_in_the_demo_is_redrawn_not_an_error(paper_sim):
    # seed 0 episode 14 under the paper settings: the first draw's rope joints go to NaN during the
    # demonstrator's first phase (found by the 1,725-episode paper rows as `sim_error` at reset)
    paper_sim.reset_state("straighten_rope", 0, 14)
    assert np.isfinite(paper_sim.task.head.entity.pose.p).all()
