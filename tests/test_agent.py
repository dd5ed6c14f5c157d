"""The X-ICM loop on the real simulator: success, and every failure kind ending one episode."""

import pytest

from xicm.core.agent import XICMAgent
from xicm.core.errors import LLMError
from xicm.core.interfaces import LLM, Detector
from xicm.core.plugins import get_registry


class ScriptedReply(LLM):
    """Test LLM that answers every prompt with a fixed text."""

    def __init__(self, text):
        self.text = text

    def complete(self, prompt):
        return self.text


class Unreachable(LLM):
    """Test LLM that asks for a pose far outside the robot's reach."""

    def complete(self, prompt):
        return "[[99, 99, 99, 0, 36, 36, 1]]"


class ServerDown(LLM):
    def complete(self, prompt):
        raise LLMError("the server at http://127.0.0.1:9/v1 did not answer")


class BrokenDetector(Detector):
    def detect(self, obs, names):
        raise RuntimeError("camera unplugged")


def _agent(sim, pool, llm, detector=None, k=2, max_steps=25):
    reg = get_registry()
    return XICMAgent(
        simulator=sim,
        detector=detector or reg.create("detector", {"name": "oracle"}),
        retriever=reg.create("retriever", {"name": "random"}, encoder=None),
        prompt_builder=reg.create("prompt", {"name": "xicm"}),
        llm=llm,
        pool=pool,
        k=k,
        max_steps=max_steps,
    )


def test_the_whole_loop_replays_each_demo_on_its_own_scene(sim, smoke_pool):
    """nearest_demo on the demo's own scene: detection, text, parsing and execution must
    reproduce the demo's success through 1 cm / 5 degree quantisation."""
    _, pool = smoke_pool
    llm = get_registry().create("llm", {"name": "nearest_demo"})
    results = [_agent(sim, [demo], llm, k=1).run_episode(demo.task, demo.seed, demo.episode) for demo in pool]
    for demo, r in zip(pool, results):
        assert r.retrieved == [demo.demo_id]
        assert r.prompt_hash and len(r.responses) == 1
        assert {"reset", "detect", "retrieve", "prompt", "llm", "parse", "execute", "total"} <= set(r.timings)
    failed = [(d.demo_id, r.error_kind, r.error_message) for d, r in zip(pool, results) if not r.success]
    assert not failed


def test_nearest_demo_on_new_scenes_reports_each_outcome(sim, smoke_pool):
    _, pool = smoke_pool
    reg = get_registry()
    agent = _agent(sim, pool, reg.create("llm", {"name": "nearest_demo"}), k=1)
    for e in range(2):
        r = agent.run_episode("push_buttons", seed=0, episode=e)
        assert r.retrieved and r.retrieved[0].startswith(("push_buttons/", "open_drawer/"))
        assert r.success or r.error_kind in ("max_steps", "unreachable"), r


@pytest.mark.parametrize(
    "llm, kind",
    [
        (ScriptedReply("I am sorry, I cannot do that."), "parse_error"),
        (ScriptedReply(""), "parse_error"),
        (Unreachable(), "unreachable"),
        (ServerDown(), "llm_error"),
    ],
)
def test_bad_replies_end_the_episode_with_a_kind(sim, smoke_pool, llm, kind):
    _, pool = smoke_pool
    r = _agent(sim, pool, llm).run_episode("close_microwave", seed=0, episode=0)
    assert not r.success
    assert r.error_kind == kind and r.error_message


def test_a_detector_crash_is_a_detector_error(sim, smoke_pool):
    _, pool = smoke_pool
    r = _agent(sim, pool, ScriptedReply("[]"), detector=BrokenDetector()).run_episode("push_buttons", 0, 0)
    assert r.error_kind == "detector_error" and "camera unplugged" in r.error_message


def test_actions_that_do_nothing_run_out_of_steps_and_reask_the_llm(sim, smoke_pool):
    _, pool = smoke_pool
    # hover above the table: reachable, never a success
    llm = ScriptedReply("[[40, 50, 40, 0, 36, 36, 1], [42, 50, 40, 0, 36, 36, 1]]")
    r = _agent(sim, pool, llm, max_steps=5).run_episode("close_microwave", 0, 0)
    assert r.error_kind == "max_steps" and r.steps == 5
    assert len(r.responses) == 3  # 2 + 2 + 1 actions: the LLM was asked again twice


def test_objects_not_detected_are_recorded_with_the_episode(sim, smoke_pool):
    _, pool = smoke_pool
    blind = get_registry().create("detector", {"name": "noisy_oracle", "drop_prob": 1.0})
    r = _agent(sim, pool, ScriptedReply("[[1, 2, 3, 0, 36, 36, 1]]"), detector=blind, max_steps=1).run_episode("close_microwave", 0, 0)
    assert r.extra["not_detected"] == ["microwave", "microwave door", "microwave door handle"]
