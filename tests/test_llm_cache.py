"""src/xicm/plugins/policies/xicm/llm_cache.py: SQLite response cache and the CachedLLM wrapper."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from xicm.core.contracts.errors import LLMError
from xicm.core.contracts.interfaces import LLM
from xicm.plugins.policies.xicm.llm_cache import CachedLLM, ResponseCache, cache_key
from xicm.core.contracts.types import Prompt, Query

WS = ((-0.3, -0.5, 0.6), (0.7, 0.5, 1.6))


class CountingLLM(LLM):
    deterministic = True

    def __init__(self, ident="counting-v1", fail=False):
        self.calls = 0
        self.ident = ident
        self.fail = fail

    def complete(self, prompt: Prompt) -> str:
        self.calls += 1
        if self.fail:
            raise LLMError("server down")
        return "reply to " + prompt.messages[-1]["content"]

    def identity(self) -> str:
        return self.ident


def make_prompt(text: str) -> Prompt:
    return Prompt(
        messages=[{"role": "system", "content": "sys"}, {"role": "user", "content": text}],
        demos=[],
        query=Query(task="t", instruction="i", objects={}),
        workspace=WS,
    )


def test_key_depends_on_identity_and_messages():
    m = [{"role": "user", "content": "a"}]
    assert cache_key("x", m) == cache_key("x", [{"content": "a", "role": "user"}])
    assert cache_key("x", m) != cache_key("y", m)
    assert cache_key("x", m) != cache_key("x", [{"role": "user", "content": "b"}])
    assert len(cache_key("x", m)) == 64


def test_hit_and_miss(tmp_path):
    inner = CountingLLM()
    llm = CachedLLM(inner, tmp_path / "c.sqlite")
    assert llm.complete(make_prompt("a")) == "reply to a"
    assert llm.complete(make_prompt("a")) == "reply to a"
    assert llm.complete(make_prompt("b")) == "reply to b"
    assert (inner.calls, llm.hits, llm.misses) == (2, 1, 2)
    assert llm.identity() == "counting-v1"


def test_persists_across_instances_and_identity_separates(tmp_path):
    path = tmp_path / "sub" / "c.sqlite"
    CachedLLM(CountingLLM(), path).complete(make_prompt("a"))
    again = CountingLLM()
    assert CachedLLM(again, path).complete(make_prompt("a")) == "reply to a"
    assert again.calls == 0
    other = CountingLLM(ident="counting-v2")
    CachedLLM(other, path).complete(make_prompt("a"))
    assert other.calls == 1
    assert len(ResponseCache(path)) == 2


def test_errors_are_not_cached(tmp_path):
    path = tmp_path / "c.sqlite"
    with pytest.raises(LLMError):
        CachedLLM(CountingLLM(fail=True), path).complete(make_prompt("a"))
    assert len(ResponseCache(path)) == 0


def test_disabled_for_nondeterministic_llms(tmp_path):
    inner = CountingLLM()
    inner.deterministic = False
    llm = CachedLLM(inner, tmp_path / "c.sqlite")
    assert not llm.enabled
    llm.complete(make_prompt("a"))
    llm.complete(make_prompt("a"))
    assert inner.calls == 2
    forced = CachedLLM(inner, tmp_path / "c.sqlite", enabled=True)
    forced.complete(make_prompt("a"))
    forced.complete(make_prompt("a"))
    assert inner.calls == 3


def test_first_writer_wins(tmp_path):
    cache = ResponseCache(tmp_path / "c.sqlite")
    cache.put("k", "first")
    cache.put("k", "second")
    assert cache.get("k") == "first"
    assert cache.get("missing") is None


WRITER = textwrap.dedent(
    """
    import sys
    from xicm.plugins.policies.xicm.llm_cache import ResponseCache
    path, tag = sys.argv[1], sys.argv[2]
    cache = ResponseCache(path, timeout_s=60)
    for i in range(300):
        cache.put(f"{tag}-{i}", f"{tag} reply {i}", identity=tag)
        cache.put(f"shared-{i}", f"shared reply {i}")
        assert cache.get(f"{tag}-{i}") == f"{tag} reply {i}"
    print("done", len(cache))
    """
)


def test_two_processes_write_concurrently(tmp_path):
    path = tmp_path / "c.sqlite"
    ResponseCache(path)  # created up front, as a run does before starting workers
    procs = [
        subprocess.Popen([sys.executable, "-c", WRITER, str(path), tag], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        for tag in ("p1", "p2")
    ]
    for proc in procs:
        out, err = proc.communicate(timeout=120)
        assert proc.returncode == 0, err.decode()
        assert out.decode().startswith("done")
    cache = ResponseCache(path)
    assert len(cache) == 900
    assert cache.get("p1-299") == "p1 reply 299"
    assert cache.get("p2-0") == "p2 reply 0"
    assert cache.get("shared-7") == "shared reply 7"


def test_the_cache_says_how_many_requests_its_llm_serves_at_once(tmp_path):
    """XICMPolicy reads concurrent_requests through the cache to decide whether its envs=N slots
    act at the same time (Policy.acts_concurrently)."""
    from xicm.plugins.policies.xicm.policy import XICMPolicy

    serial, slotted = CountingLLM(), CountingLLM()
    slotted.concurrent_requests = 3
    cached = {name: CachedLLM(llm, tmp_path / "r.sqlite") for name, llm in (("serial", serial), ("slotted", slotted))}
    assert cached["serial"].concurrent_requests == 1 and cached["slotted"].concurrent_requests == 3

    def policy(llm):
        return XICMPolicy(detector=None, retriever=None, prompt_builder=None, llm=llm, pool=[], workspace=WS)

    assert not policy(cached["serial"]).acts_concurrently
    assert policy(cached["slotted"]).acts_concurrently
