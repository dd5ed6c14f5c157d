"""The oracle policy: scripted solutions as an evaluation row."""

import pytest

from xicm.core.oracle import OracleAgent

pytest.importorskip("sapien")


def test_oracle_solves_an_episode_and_counts_its_key_actions(sim):
    result = OracleAgent(sim, max_steps=25).run_episode("close_microwave", 0, 0)
    assert result.success and result.error_kind is None
    assert 2 <= result.steps <= 25
    assert result.timings["execute"] > 0 and result.timings["total"] >= result.timings["execute"]


def test_oracle_longer_than_max_steps_is_a_failure(sim):
    result = OracleAgent(sim, max_steps=1).run_episode("close_microwave", 0, 0)
    assert not result.success and result.error_kind == "max_steps"
    assert "key actions (max_steps 1)" in result.error_message


def test_oracle_unknown_task_is_recorded_not_raised(sim):
    result = OracleAgent(sim).run_episode("make_coffee", 0, 0)
    assert not result.success and result.error_kind == "sim_error" and "make_coffee" in result.error_message
