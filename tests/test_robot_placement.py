"""simulator.robot: where the Panda stands and how it starts (scene.py ROBOT_PLACEMENTS)."""

from __future__ import annotations

import numpy as np
import pytest

from xicm.core.contracts.errors import ConfigError
from xicm.core.assembly.plugins import get_registry
from xicm.plugins.simulators.sapien.options import ROBOTS
from xicm.plugins.simulators.sapien.scene import ROBOT_PLACEMENTS, TABLE_TOP_Z


def simulator(**options):
    return get_registry().create_simulator({"name": "sapien", "render": False, **options})


def test_every_robot_option_has_a_placement():
    assert set(ROBOTS) == set(ROBOT_PLACEMENTS)


def test_rlbench_puts_the_base_and_start_pose_where_rlbench_recorded_them():
    ours, rlbench = simulator(), simulator(robot="rlbench")
    for sim in (ours, rlbench):
        sim.reset_state("open_drawer", 0, 0)
    assert np.allclose(ours.robot.base_pose.p, [-0.35, 0.0, TABLE_TOP_Z])
    assert np.allclose(rlbench.robot.base_pose.p, [-0.26765, -0.0053, TABLE_TOP_Z + 0.0003], atol=1e-4)
    assert np.allclose(rlbench.robot.arm_qpos(), [0.0, 0.1752, 0.0, -0.8731, 0.0, 1.2216, 0.7854], atol=2e-3)
    # the start TCP: high above the grid's centre for RLBench's Panda, lower and further back for ours
    assert np.allclose(rlbench.robot.tcp_pose().p, [0.287, -0.0125, 1.448], atol=0.01)
    assert np.allclose(ours.robot.tcp_pose().p, [0.07, 0.0, 1.25], atol=0.02)
    # the same task scene either way (the task's ranges are in the world's frame)
    assert np.allclose(ours.task.cabinet.get_root_pose().p, rlbench.task.cabinet.get_root_pose().p)
    assert rlbench.demonstrate().success


def test_an_unknown_robot_is_one_sentence():
    with pytest.raises(ConfigError, match=r"simulator.robot must be one of ours, rlbench"):
        get_registry().check_options("simulator", {"name": "sapien", "robot": "ur5"})
