"""Policies through the one episode runner: the oracle, and what the runner does with any policy."""

import pytest

from xicm.core.execution.episode import run_episode
from xicm.core.contracts.errors import EpisodeFailure
from xicm.core.contracts.interfaces import Policy
from xicm.core.contracts.types import KeyAction
from xicm.plugins.policies.oracle import OraclePolicy

DOWN = (0.0, 1.0, 0.0, 0.0)


class Scripted(Policy):
    """A test policy: replies with the given batches in turn; records what it saw."""

    def __init__(self, *batches):
        self.batches = list(batches)
        self.seen = []

    def reset(self, task, obs, rng):
        self.rng_draw = rng.random()

    def act(self, obs):
        self.seen.append(obs.instruction)
        batch = self.batches.pop(0)
        if isinstance(batch, Exception):
            raise batch
        return batch

    def record(self):
        return {"responses": [str(len(self.seen))], "timings": {"think": 0.5}, "extra": {"note": "hi"}}


def test_oracle_policy_solves_an_episode_without_rendering_between_steps(sim):
    result = run_episode(sim, OraclePolicy(sim), "close_microwave", 0, 0, max_steps=25)
    assert result.success and result.error_kind is None and 2 <= result.steps <= 25
    assert "observe" not in result.timings and result.timings["execute"] > 0


def test_oracle_policy_over_budget_is_a_failure(sim):
    result = run_episode(sim, OraclePolicy(sim), "close_microwave", 0, 0, max_steps=1)
    assert not result.success and result.error_kind == "max_steps" and result.steps == 1


def test_oracle_policy_whose_solution_ends_early_says_so(sim, monkeypatch):
    sim.reset_state("close_microwave", 0, 0)
    monkeypatch.setattr(sim, "scripted_solution", lambda: iter([KeyAction((0.1, 0.0, 1.1), DOWN, True)]))
    result = run_episode(sim, OraclePolicy(sim), "close_microwave", 0, 0)
    assert result.error_kind == "solution_ended" and result.steps == 1


def test_runner_executes_batches_observes_between_them_and_keeps_the_record(sim):
    stay = [KeyAction((0.07, 0.0, 1.2), DOWN, True)]
    policy = Scripted(stay * 2, stay, [])
    result = run_episode(sim, policy, "close_microwave", 3, 1, max_steps=10)
    assert result.error_kind == "no_actions" and result.steps == 3 and len(policy.seen) == 3
    assert result.responses == ["3"] and result.extra == {"note": "hi"} and result.timings["think"] == 0.5
    assert result.timings["observe"] > 0
    again = Scripted([])
    run_episode(sim, again, "close_microwave", 3, 1)
    assert again.rng_draw == policy.rng_draw  # the policy's generator is the episode's own


@pytest.mark.parametrize(
    "raised, kind",
    [(EpisodeFailure("parse_error", "no actions in reply"), "parse_error"), (ValueError("boom"), "internal_error")],
)
def test_a_policy_that_raises_ends_only_its_episode(sim, raised, kind):
    result = run_episode(sim, Scripted(raised), "close_microwave", 0, 0)
    assert not result.success and result.error_kind == kind and result.timings["total"] > 0


def test_unreachable_action_is_the_episode_outcome(sim):
    result = run_episode(sim, Scripted([KeyAction((5.0, 0.0, 1.0), DOWN, True)]), "close_microwave", 0, 0)
    assert result.error_kind == "unreachable" and "outside the workspace" in result.error_message


def test_a_simulator_without_scripted_solutions_says_so(sim):
    from xicm.core.contracts.interfaces import Simulator

    class Bare(type(sim)):
        scripted_solution = Simulator.scripted_solution  # the interface's default

    bare = Bare.__new__(Bare)
    with pytest.raises(NotImplementedError, match="Bare has no scripted solutions"):
        bare.scripted_solution()


def test_joint_actions_are_executed_like_key_actions(sim):
    import numpy as np
    import sapien

    from xicm.core.contracts.types import JointAction

    sim.reset_state("close_microwave", 0, 0)
    q0 = sim.robot.arm_qpos()
    target = sim.robot.ik(sim.robot.tcp_pose_at(q0) * sapien.Pose([0.0, 0.05, 0.05]), q0)
    assert target is not None
    policy = Scripted([JointAction(tuple(target), False)], [JointAction((9.0,) * 7, True)])
    result = run_episode(sim, policy, "close_microwave", 0, 0)
    assert result.steps == 2 and result.error_kind == "unreachable" and "outside the Panda's limits" in result.error_message
    np.testing.assert_allclose(sim.robot.arm_qpos(), target, atol=0.02)
    assert not sim.robot.gripper_open
