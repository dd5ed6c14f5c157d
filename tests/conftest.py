"""Shared fixtures. The SAPIEN simulator is expensive to start (first render compiles
shaders), so tests that need one share a session-wide instance."""

import os

import pytest

os.environ.setdefault("WANDB_MODE", "disabled")
os.environ.setdefault("HF_HUB_OFFLINE", "1")
os.environ.setdefault("TRANSFORMERS_OFFLINE", "1")


@pytest.fixture(scope="session")
def sim():
    from xicm.core.plugins import get_registry

    simulator = get_registry().create_simulator({"name": "sapien", "image_size": 128})
    yield simulator
    simulator.close()


@pytest.fixture(scope="session")
def smoke_pool(sim, tmp_path_factory):
    """Two scripted demos of each seen smoke task, collected with the real simulator."""
    from xicm.core.collect import collect
    from xicm.core.dataset import load_pool
    from xicm.core.plugins import get_registry

    path = tmp_path_factory.mktemp("pool") / "smoke.h5"
    detector = get_registry().create("detector", {"name": "oracle"})
    counts = collect(sim, detector, ["open_drawer", "push_buttons"], 2, seed=10_000, out_path=path, progress=False)
    assert all(ok == 2 for ok, _ in counts.values()), counts
    return path, load_pool(path)
