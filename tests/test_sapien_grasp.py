"""`simulator.grasp`: attach (RLBench's rigid grasp, grasp.py) against friction (today's physics)."""

import dataclasses

import numpy as np
import pytest
import sapien
from task_demos import go, hold_at_release, moved


@pytest.fixture(scope="module")
def sims():
    from xicm.core.assembly.plugins import get_registry

    made = {m: get_registry().create_simulator({"name": "sapien", "render": False, "grasp": m}) for m in ("attach", "friction")}
    yield made
    for s in made.values():
        s.close()


def _drives(entity) -> list:
    return [c for c in entity.components if isinstance(c, sapien.physx.PhysxDriveComponent)]


def _in_hand(sim, entity) -> sapien.Pose:
    return sim.robot.tcp_pose().inv() * entity.pose


def test_attach_holds_the_picked_phone_rigidly_through_a_fast_swing(sims):
    sim = sims["attach"]
    sim.reset_state("phone_on_base", 0, 0)
    release = hold_at_release(sim)
    phone = sim.task.phone
    assert sim.world.grasp.held is phone and len(_drives(phone)) == 1
    before = _in_hand(sim, phone)
    lifted = moved(release, (0.0, 0.0, 0.15), gripper_open=False)
    turned = sapien.Pose(q=[np.cos(np.pi / 12), 0.0, 0.0, np.sin(np.pi / 12)]) * sapien.Pose(q=lifted.quat_wxyz)
    go(sim, dataclasses.replace(lifted, quat_wxyz=tuple(float(v) for v in turned.q)))  # up and 30 degrees about z
    go(sim, moved(release, (-0.10, 0.0, 0.08), gripper_open=False))
    after = _in_hand(sim, phone)
    assert np.linalg.norm(after.p - before.p) < 2e-3
    assert abs(abs(float(np.dot(after.q, before.q))) - 1.0) < 1e-4


def test_opening_the_gripper_releases_the_object(sims):
    sim = sims["attach"]
    sim.reset_state("phone_on_base", 1, 0)
    release = hold_at_release(sim)
    phone = sim.task.phone
    go(sim, release)
    assert sim.world.grasp.held is None and _drives(phone) == []
    assert phone.per_scene_id not in sim.task.grasped()
    assert sim.is_success()


def test_an_object_not_between_the_fingers_is_not_attached(sims):
    sim = sims["attach"]
    sim.reset_state("phone_on_base", 0, 0)
    first = next(iter(sim.task.demonstration()))  # above the phone, gripper open
    go(sim, moved(first, gripper_open=False))  # closes on air above it
    assert sim.world.grasp.held is None
    top = sim.task.phone.pose.p[2] + 0.012
    go(sim, moved(first, (0.0, 0.0, top - first.position[2] + 0.001), gripper_open=False))  # closed fingertips on its top
    assert sim.world.grasp.held is None and _drives(sim.task.phone) == []


def test_friction_mode_attaches_nothing_and_holds_by_contact(sims):
    sim = sims["friction"]
    assert sim.world.grasp is None and sim.controller.grasp is None
    sim.reset_state("phone_on_base", 0, 0)
    hold_at_release(sim)
    phone = sim.task.phone
    assert _drives(phone) == [] and phone.per_scene_id in sim.task.grasped()


def test_a_task_declares_its_graspable_objects_else_its_dynamic_actors(sims):
    sim = sims["attach"]
    sim.reset_state("phone_on_base", 0, 0)
    assert sim.world.grasp.graspable == {sim.task.phone.per_scene_id}
    sim.reset_state("water_plants", 0, 0)
    assert sim.world.grasp.graspable == {sim.task.can.per_scene_id}


def test_an_unknown_grasp_mode_is_one_clear_sentence():
    from xicm.core.contracts.errors import ConfigError
    from xicm.core.assembly.plugins import get_registry

    with pytest.raises(ConfigError, match="^simulator.grasp must be one of attach, friction, not 'glue'$"):
        get_registry().create_simulator({"name": "sapien", "render": False, "grasp": "glue"})
