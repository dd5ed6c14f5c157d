"""simulator.scenes: rlbench draws RLBench's ranges and redraws a scene until the task's scripted
solution solves it (RLBench's evaluation episodes are scenes its demonstrator solved)."""

from __future__ import annotations

import numpy as np
import pytest
from xicm.core.errors import ConfigError, EpisodeFailure
from xicm.core.plugins import get_registry
from xicm.plugins.simulators.sapien.task_base import yaw_of


def simulator(**options):
    return get_registry().create_simulator({"name": "sapien", "render": False, **options})


def test_rlbench_scenes_are_redrawn_until_solved_and_reach_beyond_our_range():
    sim, ours = simulator(scenes="rlbench"), simulator()
    draws, yaws = [], []
    for episode in range(6):  # lamp_on seed 0: episodes 0, 1, 4 need a second or third draw (measured)
        sim.reset_state("lamp_on", 0, episode)
        draws.append(sim.scene_draw)
        yaws.append(np.rad2deg(yaw_of(sim.task.lamp.get_root_pose())))
        assert sim.demonstrate().success, episode  # the accepted draw, set up afresh, is solved again
    assert draws == [1, 2, 0, 0, 1, 0]
    assert min(yaws) < -90  # past our own +-90 degrees
    for episode in range(6):  # scenes: ours never redraws and keeps its own range
        ours.reset_state("lamp_on", 0, episode)
        assert ours.scene_draw == 0 and abs(np.rad2deg(yaw_of(ours.task.lamp.get_root_pose()))) <= 90

def test_no_solvable_draw_fails_the_episode_with_a_reason():
    sim = simulator(scenes="rlbench", max_scene_draws=1)
    with pytest.raises(EpisodeFailure, match=r"lamp_on seed 0 episode 0: the scripted solution solved none of 1 scenes") as failure:
        sim.reset_state("lamp_on", 0, 0)
    assert failure.value.kind == "unsolvable_scene"


def test_an_unknown_scenes_value_is_one_sentence():
    with pytest.raises(ConfigError, match=r"simulator.scenes"):
        get_registry().check_options("simulator", {"name": "sapien", "scenes": "wide"})
