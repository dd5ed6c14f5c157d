"""envs=N: episodes on N simulator processes in lockstep, the policy asked once per round."""

import threading
import time

import pytest
from hydra import compose, initialize_config_module

from xicm.core.execution.batched_envs import BatchedEnvs, Lockstep, SlotPolicy
from xicm.core.assembly.checks import CheckInput, run_modes
from xicm.core.assembly.plugins import get_registry
from xicm.core.execution.episode import run_episode
from xicm.core.contracts.errors import ConfigError
from xicm.core.contracts.interfaces import Policy
from xicm.plugins.policies.oracle import OraclePolicy


class Counting(Policy):
    """Records the size of every act_batch call it leads."""

    batches: list[int] = []

    def __init__(self, slot):
        self.slot = slot

    def act(self, obs):
        if obs == "fail":
            raise RuntimeError(f"slot {self.slot} failed")
        return [obs]

    def act_batch(self, peers, observations):
        Counting.batches.append(len(peers))
        return super().act_batch(peers, observations)


def test_lockstep_asks_once_per_round_for_every_waiting_environment():
    Counting.batches = []
    policies = [Counting(i) for i in range(3)]
    lockstep = Lockstep(policies)
    answers = {i: [] for i in range(3)}

    def slot(i, rounds):
        lockstep.join(i)
        for r in range(rounds):
            time.sleep(0.01 * (3 - i))  # they arrive at different times
            try:
                answers[i].append(lockstep.act(i, "fail" if (i, r) == (1, 0) else (i, r)))
            except RuntimeError as exc:
                answers[i].append(str(exc))
        lockstep.leave(i)

    threads = [threading.Thread(target=slot, args=(i, 2 if i == 2 else 3)) for i in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=10)
    assert Counting.batches == [3, 3, 2]  # slot 2 ran two rounds, then left
    assert answers[0] == [[(0, 0)], [(0, 1)], [(0, 2)]]
    assert answers[1] == ["slot 1 failed", [(1, 1)], [(1, 2)]]  # an exception reaches only its own slot
    assert answers[2] == [[(2, 0)], [(2, 1)]]


def compose_cfg(*overrides):
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        return compose(config_name="config", overrides=list(overrides))


@pytest.mark.parametrize(
    "overrides, words",
    [
        (["envs=2", "shards.backend=ray"], "envs=2 needs shards.backend=local"),
        (["envs=2", "video.enabled=true"], "envs=2 cannot record videos"),
    ],
)
def test_envs_that_cannot_work_stop_at_start(overrides, words):
    with pytest.raises(ConfigError, match=words):
        run_modes(CheckInput(compose_cfg(*overrides), get_registry(), []))


@pytest.mark.slow
@pytest.mark.subprocess
def test_two_environments_give_the_episodes_of_one(sim):
    cfg = compose_cfg("policy=oracle", "simulator.image_size=32", "benchmark.tasks=[open_drawer,push_buttons]")
    cfg.run_name = cfg.tracking.group = "test"  # their ${hydra:...} resolves only inside a Hydra app
    keys = [(t, 0, e) for t in ("open_drawer", "push_buttons") for e in range(2)]
    batched = BatchedEnvs(cfg, 2, {"max_steps": 25}, keys)
    try:
        results = [batched(*k) for k in keys]
    finally:
        batched.close()
    alone = [run_episode(sim, OraclePolicy(sim), *k) for k in keys]

    def facts(r):
        return (r.task, r.seed, r.episode, r.success, r.steps, r.error_kind)

    assert [facts(r) for r in results] == [facts(r) for r in alone]
    assert all(r.success for r in alone)


class Overlapping(Policy):
    """Acts concurrently; records how many of its instances are inside act at once."""

    acts_concurrently = True
    inside = 0
    most = 0
    lock = threading.Lock()

    def act(self, obs):
        with Overlapping.lock:
            Overlapping.inside += 1
            Overlapping.most = max(Overlapping.most, Overlapping.inside)
        time.sleep(0.2)
        with Overlapping.lock:
            Overlapping.inside -= 1
        return [obs]


def test_a_policy_that_acts_concurrently_skips_the_lockstep():
    """Its slots call their own instance at the same time (no act_batch round), so two slots'
    requests overlap; a Lockstep over such a policy would answer them one after the other."""
    Overlapping.most = 0
    slots = [SlotPolicy(Overlapping(), None, i) for i in range(2)]
    answers = {}
    threads = [threading.Thread(target=lambda i=i: answers.setdefault(i, slots[i].act(i))) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=10)
    assert answers == {0: [0], 1: [1]} and Overlapping.most == 2

    Overlapping.most = 0
    lockstep = Lockstep([Overlapping(), Overlapping()])
    for i in range(2):
        lockstep.join(i)
    threads = [threading.Thread(target=lambda i=i: lockstep.act(i, i)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=10)
    assert Overlapping.most == 1  # the default act_batch: one after the other
