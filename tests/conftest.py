"""Shared fixtures; plugins for the lanes' markers (lanes.py), the cached builds started beside
the suite (prebuild.py), the test order (file_order.py) and the strict-skip rule (strict_skips.py).

Lanes (markers in pyproject.toml): `pytest -m "not slow"` is the developer's fast lane;
`bash scripts/test.sh` (CI) runs everything. XICM_TEST_ORDER=reverse (or --reverse-files) runs
the files in reverse order, each file's tests in their own order: no test may depend on another
file's having run first."""

import os

import pytest

os.environ.setdefault("WANDB_MODE", "disabled")
os.environ.setdefault("HF_HUB_OFFLINE", "1")
os.environ.setdefault("TRANSFORMERS_OFFLINE", "1")

pytest_plugins = ["lanes", "prebuild", "file_order", "strict_skips", "pytester"]


@pytest.fixture(scope="session")
def sim():
    """One rendering SAPIEN simulator for the session (a process's first render compiles shaders,
    ~7 s): for tests that render. Tests of physics alone take `physics_sim`."""
    from xicm.core.assembly.plugins import get_registry

    simulator = get_registry().create_simulator({"name": "sapien", "image_size": 128})
    yield simulator
    simulator.close()


@pytest.fixture
def physics_sim():
    """A fresh physics-only SAPIEN simulator (render=False, ~0.02 s to build) for each test of
    physics alone. (Every reset builds a new scene, so a shared simulator would repeat too.)"""
    from xicm.core.assembly.plugins import get_registry

    simulator = get_registry().create_simulator({"name": "sapien", "render": False})
    yield simulator
    simulator.close()


@pytest.fixture(scope="session")
def smoke_pool(sim, tmp_path_factory):
    """Two scripted demos of each seen smoke task, collected with the real simulator."""
    from xicm.core.execution.collect import collect
    from xicm.core.results.dataset import load_pool
    from xicm.core.assembly.plugins import get_registry

    path = tmp_path_factory.mktemp("pool") / "smoke.h5"
    detector = get_registry().create("detector", {"name": "oracle"})
    counts = collect(sim, detector, ["open_drawer", "push_buttons"], 2, seed=10_000, out_path=path, progress=False)
    assert all(ok == 2 for ok, _ in counts.values()), counts
    return path, load_pool(path)


@pytest.fixture(scope="session")
def tiny_gemma_dir(tmp_path_factory):
    """One tiny random Gemma 3 folder (tiny_gemma.py) for every LLM test module of the session."""
    pytest.importorskip("torch")
    pytest.importorskip("transformers")
    from tiny_gemma import write_tiny_gemma

    return write_tiny_gemma(tmp_path_factory.mktemp("tiny-gemma") / "tiny-gemma3")
