"""benchmark.instructions: AGNOSTOS's instruction (default) or one of RLBench's variation-0
phrasings per episode, drawn from the episode's seed stream."""

import dataclasses

import numpy as np
import pytest

from xicm.core.contracts.errors import ConfigError
from xicm.core.assembly.instructions import episode_instruction
from xicm.core.contracts.types import KeyAction, Observation, TaskInfo



class FakeSim:
    info = TaskInfo("close_fridge", "level1", "close fridge", ("fridge",), phrasings=("close fridge", "shut the fridge", "close the fridge door"))

    def task_info(self, task):
        return self.info


def _obs(text="close fridge"):
    gripper = KeyAction((0.0, 0.0, 1.0), (0.0, 1.0, 0.0, 0.0), True)
    return Observation(text, {}, {}, ["fridge"], gripper, np.zeros(9))


def test_every_unseen_task_keeps_rlbench_phrasings_with_its_instruction_first():

    from xicm.plugins.simulators.sapien.tasks import builtin_tasks

    tasks = builtin_tasks()
    unseen = [n for n, t in tasks.items() if TaskInfo.of(n, t).split != "seen"]
    assert len(unseen) == 23
    for name in unseen:
        info = TaskInfo.of(name, tasks[name])
        assert info.phrasings[0] == info.instruction and len(info.phrasings) >= 3, name
        assert len(set(info.phrasings)) == len(info.phrasings), name


def test_every_seen_task_keeps_rlbench_phrasings_with_its_instruction_first():
    from xicm.plugins.simulators.sapien.tasks import builtin_tasks

    tasks = builtin_tasks()
    seen = [n for n, t in tasks.items() if TaskInfo.of(n, t).split == "seen"]
    assert len(seen) == 18
    for name in seen:
        info = TaskInfo.of(name, tasks[name])
        assert info.phrasings[0] == info.instruction and len(info.phrasings) >= 3, name
        assert len(set(info.phrasings)) == len(info.phrasings), name


def test_agnostos_keeps_the_instruction():
    reword = episode_instruction(FakeSim(), _obs(), "close_fridge", 0, 0, "agnostos")
    assert reword(_obs()).instruction == "close fridge"


def test_sampled_draws_one_phrasing_per_episode_from_its_seed_stream():
    drawn = [episode_instruction(FakeSim(), _obs(), "close_fridge", 0, e, "sampled")(_obs()).instruction for e in range(30)]
    assert set(drawn) == set(FakeSim.info.phrasings)  # 30 draws from 3 reach all of them
    again = [episode_instruction(FakeSim(), _obs(), "close_fridge", 0, e, "sampled")(_obs()).instruction for e in range(30)]
    assert again == drawn
    reword = episode_instruction(FakeSim(), _obs(), "close_fridge", 0, 3, "sampled")
    assert reword(_obs()).instruction == reword(dataclasses.replace(_obs(), cameras={"front": None})).instruction


def test_sampled_leaves_another_variation_s_instruction():
    other = _obs("open the fridge")  # not variation 0's instruction
    assert episode_instruction(FakeSim(), other, "close_fridge", 0, 0, "sampled")(other).instruction == "open the fridge"


def test_an_unknown_choice_is_one_clear_sentence():
    from xicm.core.assembly.config_schema import XicmConfig
    from xicm.core.contracts.schema import check_overrides

    with pytest.raises(ConfigError, match="benchmark.instructions"):
        check_overrides(["benchmark.instructions=random"], XicmConfig)
