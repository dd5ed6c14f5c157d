"""noisy_oracle: seeded position noise, dropped objects and swapped names on top of the oracle."""

import numpy as np
import pytest

from test_detector_oracle import look_at, obs_of, patch_frame
from xicm.core.contracts.errors import ConfigError
from xicm.core.assembly.plugins import get_registry
from xicm.plugins.detectors.noisy_oracle import NoisyOracleDetector, NoisyOracleOptions
from xicm.plugins.detectors.oracle import OracleDetector

NAMES = ["a", "b", "c", "d"]


def scene(shift=0):
    pose = look_at([1.0, 0.0, 1.5], [0.0, 0.0, 0.8])
    patches = [(20 + shift, 20, 3, 1.0, 1), (60, 30, 3, 1.1, 2), (100, 50, 3, 1.2, 3), (40, 70, 3, 0.9, 4)]
    f, _ = patch_frame(pose, patches)
    return obs_of({"front": f}, {1: "a", 2: "b", 3: "c", 4: "d"}, names=NAMES)


def test_zero_errors_is_the_oracle_and_it_is_registered():
    obs = scene()
    assert NoisyOracleDetector().detect(obs, NAMES) == OracleDetector().detect(obs, NAMES)
    det = get_registry().create("detector", {"name": "noisy_oracle", "noise_cm": 1.0})
    assert isinstance(det, NoisyOracleDetector)


def test_noise_has_the_configured_size_and_repeats_for_the_same_scene():
    truth = OracleDetector().detect(scene(), NAMES)
    errors = []
    for shift in range(30):  # 30 scenes: the draw depends on the scene
        obs = scene(shift)
        truth = OracleDetector().detect(obs, NAMES)
        noisy = NoisyOracleDetector(NoisyOracleOptions(noise_cm=2.0, seed=3)).detect(obs, NAMES)
        assert noisy == NoisyOracleDetector(NoisyOracleOptions(noise_cm=2.0, seed=3)).detect(obs, NAMES)  # a fresh instance agrees
        errors += [np.subtract(noisy[n], truth[n]) for n in NAMES]
    std = np.std(np.concatenate(errors))
    assert 0.015 < std < 0.025  # 2 cm per axis
    other_seed = NoisyOracleDetector(NoisyOracleOptions(noise_cm=2.0, seed=4)).detect(scene(), NAMES)
    assert other_seed != NoisyOracleDetector(NoisyOracleOptions(noise_cm=2.0, seed=3)).detect(scene(), NAMES)


def test_drop_and_swap_rates():
    dropped = swapped = 0
    for shift in range(40):
        obs = scene(shift)
        truth = OracleDetector().detect(obs, NAMES)
        out = NoisyOracleDetector(NoisyOracleOptions(drop_prob=0.25, seed=1)).detect(obs, NAMES)
        dropped += len(NAMES) - len(out)
        assert all(out[n] == truth[n] for n in out)
        out = NoisyOracleDetector(NoisyOracleOptions(swap_prob=0.5, seed=1)).detect(obs, NAMES)
        moved = [n for n in NAMES if out[n] != truth[n]]
        assert len(moved) in (0, 2)
        if moved:
            a, b = moved
            assert out[a] == truth[b] and out[b] == truth[a]
            swapped += 1
    assert 20 <= dropped <= 60  # 160 objects x 0.25 = 40 expected
    assert 10 <= swapped <= 30  # 40 scenes x 0.5 = 20 expected


@pytest.mark.parametrize(
    "option, sentence",
    [
        ({"drop_prob": 1.5}, "detector.drop_prob must be a number from 0 to 1, not 1.5"),
        ({"swap_prob": -0.1}, "detector.swap_prob must be a number from 0 to 1, not -0.1"),
        ({"noise_cm": -1}, "detector.noise_cm must be a number >= 0, not -1"),
        ({"seed": -1}, "detector.seed must be an integer >= 0, not -1"),
    ],
)
def test_bad_options_are_one_sentence(option, sentence):
    with pytest.raises(ConfigError) as err:
        get_registry().create("detector", {"name": "noisy_oracle", **option})
    assert str(err.value) == sentence
