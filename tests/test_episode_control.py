"""Per-step policies in the episode loop (src/xicm/core/execution/episode.py): ControlStep actions and chunks,
the max_control_steps budget and its per-task default, and benchmark.variations."""

import pytest
from hydra import compose, initialize_config_module

from xicm.core.assembly.build import build_run
from xicm.core.execution.episode import run_episode
from xicm.core.contracts.interfaces import Policy
from xicm.core.contracts.types import ControlStep

TASK = "open_drawer"


def _compose(*overrides):
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        return compose("config", overrides=["simulator.render=false", *overrides])


class ChunkReplay(Policy):
    """Answers with the whole recorded action sequence as one chunk of ControlSteps."""

    observes = False

    def __init__(self, actions, chunk=None):
        self.actions = [ControlStep(tuple(float(v) for v in a)) for a in actions]
        self.chunk = chunk or len(self.actions)
        self.calls = 0

    def act(self, obs):
        start = self.calls * self.chunk
        self.calls += 1
        return self.actions[start : start + self.chunk] or [ControlStep((0.0,) * 6 + (1.0,))]


class PhysicsOnly:
    """The simulator without rendering: reset() sets the state and skips the observation."""

    def __init__(self, sim):
        self.sim = sim

    def __getattr__(self, name):
        return getattr(self.sim, name)

    def reset(self, task, seed, episode):
        self.sim.reset_state(task, seed, episode)


@pytest.fixture(scope="module")
def run():
    built = build_run(_compose(), with_policy=False)
    yield built
    built.close()


@pytest.fixture(scope="module")
def recording(run):
    run.simulator.reset_state(TASK, 0, 0)
    return run.simulator.record_scripted()


def test_a_chunk_of_control_steps_replays_a_recorded_demo_to_success(run, recording):
    policy = ChunkReplay(recording.actions["ee_delta"], chunk=8)
    result = run_episode(PhysicsOnly(run.simulator), policy, TASK, 0, 0, max_steps=25)
    assert (result.success, result.error_kind) == (True, None)
    assert 0.6 * recording.steps < result.steps <= recording.steps  # control steps, not key actions
    assert policy.calls == -(-result.steps // 8)
    assert "step" in result.timings and "execute" not in result.timings


def test_control_steps_run_out_at_max_control_steps_not_max_steps(run, recording):
    policy = ChunkReplay(recording.actions["ee_delta"], chunk=3)
    result = run_episode(PhysicsOnly(run.simulator), policy, TASK, 0, 0, max_steps=2, max_control_steps=7)
    assert (result.success, result.steps, result.error_kind) == (False, 7, "max_control_steps")
    assert result.error_message == "no success within 7 control steps"


def test_without_max_control_steps_the_task_default_is_the_budget(run):
    budget = run.simulator.task_info(TASK).max_control_steps
    policy = ChunkReplay([], chunk=1)  # holds still for ever
    result = run_episode(PhysicsOnly(run.simulator), policy, TASK, 0, 0, max_steps=25)
    assert (result.error_kind, result.steps) == ("max_control_steps", budget)


def test_a_bad_control_step_fails_the_episode_with_its_reason(run):
    policy = ChunkReplay([[0.0, 0.0, float("nan"), 0.0, 0.0, 0.0, 1.0]])
    result = run_episode(PhysicsOnly(run.simulator), policy, TASK, 0, 0)
    assert (result.success, result.steps, result.error_kind) == (False, 1, "bad_action")
    assert "NaN or infinite values at index(es) [2]" in result.error_message


def test_every_registered_task_declares_a_control_step_budget():
    from xicm.core.assembly.plugins import get_registry

    registry = get_registry()
    budgets = {t: registry.task_info(t).max_control_steps for t in registry.tasks(simulator="sapien")}
    assert len(budgets) == 41 and all(isinstance(b, int) and b >= 20 for b in budgets.values()), budgets


@pytest.mark.parametrize("variations, instructions", [("zero", 1), ("sampled", 11)])
def test_benchmark_variations_picks_variation_zero_or_samples_one_per_episode(variations, instructions):
    """push_buttons' variations differ in colours and order: 12 sampled episodes gave 11 instructions."""
    built = build_run(_compose("benchmark=seen", f"benchmark.variations={variations}"), with_policy=False)
    try:
        seen = set()
        for episode in range(12):
            built.simulator.reset_state("push_buttons", 0, episode)
            seen.add(built.simulator.task.episode_instruction)
    finally:
        built.close()
    assert len(seen) == instructions


def test_benchmark_variations_sets_the_simulators_sample_variations():
    built = build_run(_compose("benchmark.variations=zero", "simulator.render=false"), with_policy=False)
    try:
        assert built.simulator.sample_variations is False
    finally:
        built.close()


def test_an_unknown_benchmark_variations_value_is_one_sentence():
    from xicm.core.contracts.errors import ConfigError
    from xicm.core.assembly.checks import check_run
    from xicm.core.assembly.plugins import get_registry

    cfg = _compose("benchmark.variations=all")
    with pytest.raises(ConfigError, match="benchmark.variations must be one of zero, sampled, not 'all'"):
        check_run(cfg, get_registry(), list(cfg.benchmark.tasks))
