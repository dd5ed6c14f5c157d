"""grounding_dino detector: the real transformers architecture, tiny and randomly initialised
(the weights are not on this machine), run end to end offline; plus its 3D lifting on exact
synthetic geometry and the one-sentence error for a missing checkpoint."""

from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("transformers")
pytest.importorskip("torch")

from test_detector_oracle import H, W, look_at, patch_frame  # noqa: E402
from tiny_grounding_dino import build_tiny_grounding_dino  # noqa: E402

from xicm.core.contracts.errors import ConfigError  # noqa: E402
from xicm.plugins.detectors.grounding_dino import GroundingDinoDetector, lift_box, name_token_spans  # noqa: E402
from xicm.plugins.detectors.grounding_dino import GroundingDinoOptions  # noqa: E402

NAMES = ["microwave", "microwave door", "microwave door handle"]


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    return build_tiny_grounding_dino(tmp_path_factory.mktemp("gdino"), NAMES + ["top drawer handle"])


@pytest.mark.parametrize("model", ["IDEA-Research/grounding-dino-tiny", "/nowhere/grounding-dino"])
def test_a_missing_checkpoint_is_one_clear_sentence(model, monkeypatch):
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    with pytest.raises(ConfigError, match=r"could not be loaded from this machine .*detector.model=/path/to/a/local/copy") as err:
        GroundingDinoDetector(GroundingDinoOptions(model=model))
    assert "\n" not in str(err.value)


def test_name_token_spans(tiny):
    det = GroundingDinoDetector(GroundingDinoOptions(model=str(tiny)))
    caption = " . ".join(NAMES) + " ."
    spans = name_token_spans(det.processor.tokenizer, caption, NAMES)
    tokens = det.processor.tokenizer(caption).input_ids
    words = det.processor.tokenizer.convert_ids_to_tokens(tokens)
    assert [[words[i] for i in s] for s in spans] == [n.split() for n in NAMES]


def test_lift_box_finds_the_object_not_the_background():
    pose = look_at([1.0, 0.0, 1.5], [0.0, 0.0, 0.8])
    frame, (centre,) = patch_frame(pose, [(60, 40, 6, 0.9, 1)])
    depth = np.asarray(frame.depth)
    depth[depth == 0] = 1.6  # a table far behind the object
    box = (60 - 9, 40 - 9, 60 + 9, 40 + 9)  # a loose box: background around the patch
    np.testing.assert_allclose(lift_box(frame, box), centre, atol=1e-6)
    assert lift_box(replace(frame, depth=np.zeros((H, W), np.float32)), box) is None


def test_end_to_end_on_a_simulator_observation(tiny, sim):
    obs = sim.reset("close_microwave", 0, 0)
    det = GroundingDinoDetector(GroundingDinoOptions(model=str(tiny), box_threshold=0.0, text_threshold=0.0))
    found = det.detect(obs, list(obs.object_names))
    assert list(found) == NAMES  # a random model still grounds every name somewhere
    for xyz in found.values():
        assert np.all(np.isfinite(xyz)) and 0.5 < xyz[2] < 2.0
    assert det.detect(obs, list(obs.object_names)) == found  # deterministic
    strict = GroundingDinoDetector(GroundingDinoOptions(model=str(tiny), box_threshold=1.01))
    assert strict.detect(obs, list(obs.object_names)) == {}  # nothing passes: all "not detected"
    only_front = GroundingDinoDetector(GroundingDinoOptions(model=str(tiny), box_threshold=0.0, text_threshold=0.0, cameras=["front"]))
    assert set(only_front.detect(obs, ["microwave"])) == {"microwave"} and len(det.seconds) == 2
