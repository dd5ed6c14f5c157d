"""simulator.workspace_check: rlbench refuses targets outside RLBench's workspace in z (the table
top to 1 m above it) with their own error kind; x/y stay the grid box's."""

import numpy as np
import pytest

from xicm.core.contracts.errors import ERROR_KINDS
from xicm.core.assembly.plugins import get_registry
from xicm.core.contracts.types import KeyAction

DOWN = (0, 1, 0, 0)


@pytest.fixture(params=["grid", "rlbench"])
def checked(request):
    sim = get_registry().create_simulator({"name": "sapien", "render": False, "workspace_check": request.param})
    sim.reset_state("push_buttons", 0, 0)
    yield sim
    sim.close()


def _try(sim, position):
    before = sim.robot.arm_qpos()
    outcome = sim.execute(KeyAction(position, DOWN, True))
    return outcome, np.allclose(sim.robot.arm_qpos(), before, atol=1e-3)


@pytest.mark.parametrize("z, where", [(1.80, "above"), (0.70, "below")])
def test_a_target_off_rlbenchs_z_range_is_out_of_workspace(checked, z, where):
    outcome, still = _try(checked, (0.2, 0.0, z))
    assert not outcome.ok and still  # refused before any move
    if checked.workspace_check == "rlbench":
        assert outcome.error_kind == "out_of_workspace"
        assert "outside RLBench's workspace in z (0.75 to 1.75 m" in outcome.error_message
    else:
        assert outcome.error_kind == "unreachable"


def test_above_the_grid_but_within_rlbenchs_workspace_only_the_grid_refuses(checked):
    outcome, _ = _try(checked, (0.0, 0.0, 1.65))  # z index 105: off the grid, 0.9 m over the table
    if checked.workspace_check == "grid":
        assert outcome.error_kind == "unreachable" and "outside the workspace box" in outcome.error_message
    else:  # RLBench plans to it: no workspace refusal; pointing down, the Panda cannot reach it
        assert outcome.ok or "no joint configuration" in outcome.error_message


def test_xy_stay_the_grid_boxs_under_either_check(checked):
    outcome, still = _try(checked, (0.75, 0.0, 1.0))
    assert (outcome.error_kind, still) == ("unreachable", True) and "outside the workspace box" in outcome.error_message


def test_the_kind_is_declared_and_a_bad_value_is_refused():
    assert "out_of_workspace" in ERROR_KINDS
    from xicm.core.contracts.errors import ConfigError

    with pytest.raises(ConfigError, match="workspace_check"):
        get_registry().create_simulator({"name": "sapien", "render": False, "workspace_check": "box"})


def test_an_episode_ends_with_the_kind(sim):
    from xicm.core.execution.episode import run_episode
    from xicm.core.contracts.interfaces import Policy

    class Upward(Policy):
        def act(self, obs):
            return [KeyAction((0.2, 0.0, 1.9), DOWN, True)]  # z voxel 130 of a reply read without a range check

    sim.workspace_check = "rlbench"
    try:
        result = run_episode(sim, Upward(), "push_buttons", 0, 0, max_steps=3)
    finally:
        sim.workspace_check = "grid"
    assert (result.error_kind, result.steps, result.success) == ("out_of_workspace", 1, False)
    assert "outside RLBench's workspace in z" in result.error_message
