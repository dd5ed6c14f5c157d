"""The X-ICM policy on the real simulator, built by its plugin factory and by hand: success,
and every failure kind ending one episode."""

import pytest
from omegaconf import OmegaConf

from xicm.core.text.encoding import format_actions
from xicm.core.execution.episode import run_episode
from xicm.core.contracts.errors import ConfigError, LLMError
from xicm.core.contracts.interfaces import LLM, Detector, PolicyContext
from xicm.core.assembly.plugins import get_registry
from xicm.core.text.reanchor import reanchor
from xicm.plugins.policies.xicm import XicmPolicyOptions, create_xicm_policy
from xicm.plugins.policies.xicm.policy import XICMPolicy


class ScriptedReply(LLM):
    """Test LLM that answers every prompt with a fixed text."""

    deterministic = True

    def __init__(self, text):
        self.text = text

    def complete(self, prompt):
        return self.text


class Unreachable(LLM):
    """Test LLM that asks for a pose far outside the robot's reach."""

    deterministic = True

    def complete(self, prompt):
        return "[[99, 99, 99, 0, 36, 36, 1]]"


class ServerDown(LLM):
    deterministic = True

    def complete(self, prompt):
        raise LLMError("the server at http://127.0.0.1:9/v1 did not answer")


class Recording(LLM):
    """Wraps an LLM and keeps every prompt it was asked."""

    deterministic = False

    def __init__(self, inner):
        self.inner, self.prompts = inner, []

    def complete(self, prompt):
        self.prompts.append(prompt)
        return self.inner.complete(prompt)


class BrokenDetector(Detector):
    def detect(self, obs, names):
        raise RuntimeError("camera unplugged")


class Episodes:
    """A policy on the session simulator: `.run(task, seed, episode)` through core.episode."""

    def __init__(self, sim, policy, max_steps=25):
        self.sim, self.policy, self.max_steps = sim, policy, max_steps

    def run_episode(self, task, seed, episode):
        return run_episode(self.sim, self.policy, task, seed, episode, self.max_steps)


def _agent(sim, pool, llm, detector=None, k=2, max_steps=25, **options):
    """XICMPolicy assembled by hand, for test LLMs and detectors that are not registered plugins."""
    reg = get_registry()
    policy = XICMPolicy(
        detector=detector or reg.create("detector", {"name": "oracle"}),
        retriever=reg.create("retriever", {"name": "random"}, encoder=None),
        prompt_builder=reg.create("prompt", {"name": "xicm"}),
        llm=llm,
        pool=pool,
        workspace=sim.workspace,
        k=k,
        **options,
    )
    return Episodes(sim, policy, max_steps)


def _factory_config(**groups):
    """The config groups create_xicm_policy reads (what `xicm-eval` composes)."""
    base = {
        "detector": {"name": "oracle"},
        "encoder": {"name": None},
        "retriever": {"name": "random"},
        "prompt": {"name": "xicm"},
        "llm": {"name": "nearest_demo"},
        "llm_cache": {"enabled": False, "path": "/nonexistent/responses.sqlite"},
    }
    return OmegaConf.create({**base, **groups})


def test_the_factory_builds_the_configured_parts_over_the_pool_file(sim, smoke_pool):
    path, pool = smoke_pool
    cfg = _factory_config(encoder={"name": "minilm"}, retriever={"name": "similarity"})
    policy = create_xicm_policy(XicmPolicyOptions(3, 2, str(path), ["push_buttons"]), PolicyContext(cfg, get_registry(), sim))
    assert (policy.k, policy.max_llm_calls, type(policy.llm).__name__) == (3, 2, "NearestDemoLLM")
    assert {d.task for d in policy.pool} == {"push_buttons"} and len(policy.pool) == 2
    meta = policy.run_metadata()
    assert (meta["pool"], meta["pool_size"]) == (str(path), 2)
    assert meta["retrieval_features"].startswith("minilm:sentence-transformers/all-MiniLM-L6-v2:"), meta


def test_the_factory_refuses_a_pool_without_the_asked_tasks(sim, smoke_pool):
    path, _ = smoke_pool
    with pytest.raises(ConfigError, match=r"holds no demos of \['close_jar'\]; collect them first"):
        create_xicm_policy(XicmPolicyOptions(2, None, str(path), ["close_jar"]), PolicyContext(_factory_config(), get_registry(), sim))


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


def test_factory_built_policy_retrieves_by_language_and_replays_the_demo_reanchored(sim, smoke_pool):
    """On new push_buttons scenes, language retrieval ranks a push_buttons demo first (the pool
    also holds open_drawer demos), and nearest_demo's first reply is exactly that demo's key
    actions moved onto the new scene's objects."""
    path, pool = smoke_pool
    cfg = _factory_config(encoder={"name": "minilm"}, retriever={"name": "similarity"})
    policy = create_xicm_policy(XicmPolicyOptions(1, 1, str(path), ["open_drawer", "push_buttons"]), PolicyContext(cfg, get_registry(), sim))
    policy.llm = Recording(policy.llm)
    for e in range(2):
        r = run_episode(sim, policy, "push_buttons", 0, e)
        prompt = policy.llm.prompts[-1]
        assert [d.demo_id for d in prompt.demos] == r.retrieved and r.retrieved[0].startswith("push_buttons/")
        assert r.responses == [format_actions(reanchor(prompt.demos[0], prompt.query), sim.workspace)]


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


class CountingRetriever:
    """Wraps a retriever and keeps the query of every selection."""

    def __init__(self, inner):
        self.inner, self.queries = inner, []

    def select(self, query, pool, k, rng):
        self.queries.append(query)
        return self.inner.select(query, pool, k, rng)


HOVER_THEN_OUT = "[[40, 50, 40, 0, 36, 36, 1], [42, 50, 40, 0, 36, 36, 1], [140, 50, 40, 0, 36, 36, 1]]"


def test_partial_replies_run_the_valid_actions_then_end_at_the_invalid_one(sim, smoke_pool):
    _, pool = smoke_pool
    r = _agent(sim, pool, ScriptedReply(HOVER_THEN_OUT), partial_replies=True).run_episode("close_microwave", 0, 0)
    assert (r.steps, r.error_kind, len(r.responses)) == (2, "parse_error", 1)
    assert r.error_message.startswith("after the valid actions of reply 1: action [140, 50, 40, 0, 36, 36, 1] is out of range")


def test_parse_fallback_reads_replies_as_xicm_does(sim, smoke_pool):
    """X-ICM's reading: the valid actions run, the off-grid one is refused when executed; a reply
    with no action moves to the default pose and the LLM is asked again."""
    _, pool = smoke_pool
    r = _agent(sim, pool, ScriptedReply(HOVER_THEN_OUT), parse_fallback=True).run_episode("close_microwave", 0, 0)
    assert (r.steps, r.error_kind, len(r.responses)) == (3, "unreachable", 1)
    # the default pose is RLBench's start pose: out of our own robot's reach, within RLBench's
    r = _agent(sim, pool, ScriptedReply("I would open it."), parse_fallback=True).run_episode("close_microwave", 0, 0)
    assert (r.steps, r.error_kind, r.extra["parse_fallbacks"]) == (1, "unreachable", ["reply 1: no group of 7 integers: one default action"])
    rlbench = get_registry().create_simulator({"name": "sapien", "robot": "rlbench", "cameras": ["front"]})
    try:
        chatty = _agent(rlbench, pool, ScriptedReply("I would open it."), parse_fallback=True, max_steps=3)
        r = chatty.run_episode("close_microwave", 0, 0)
    finally:
        rlbench.close()
    assert (r.steps, r.error_kind, len(r.responses)) == (3, "max_steps", 3)
    assert r.extra["parse_fallbacks"] == [f"reply {i}: no group of 7 integers: one default action" for i in (1, 2, 3)]


def test_by_default_one_invalid_action_rejects_the_whole_reply(sim, smoke_pool):
    _, pool = smoke_pool
    r = _agent(sim, pool, ScriptedReply(HOVER_THEN_OUT)).run_episode("close_microwave", 0, 0)
    assert (r.steps, r.error_kind) == (0, "parse_error")


@pytest.mark.parametrize("rerank, selections", [(False, 1), (True, 3)])
def test_rerank_selects_demos_again_with_each_llm_call(sim, smoke_pool, rerank, selections):
    _, pool = smoke_pool
    llm = Recording(ScriptedReply("[[40, 50, 40, 0, 36, 36, 1]]"))
    episodes = _agent(sim, pool, llm, k=1, max_steps=3, rerank=rerank)
    episodes.policy.retriever = CountingRetriever(episodes.policy.retriever)
    r = episodes.run_episode("close_microwave", 0, 0)
    assert len(llm.prompts) == 3 and len(episodes.policy.retriever.queries) == selections
    assert r.retrieved == [d.demo_id for d in llm.prompts[0].demos]
    if rerank:
        assert r.extra["retrieved_per_call"] == [[d.demo_id for d in p.demos] for p in llm.prompts]
    else:
        assert "retrieved_per_call" not in r.extra
