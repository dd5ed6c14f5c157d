"""benchmark.scene_seed: every seed replays one seed's scenes (X-ICM's 25 stored scenes), while
the policy's random stream still follows the run's seed."""

import numpy as np

from xicm.core.execution.episode import run_episode
from xicm.core.contracts.errors import EpisodeFailure
from xicm.core.contracts.interfaces import Policy


class FirstLook(Policy):
    """Test policy: keeps the first picture and one draw of its random stream, then gives up."""

    def __init__(self):
        self.seen = []

    def reset(self, task, obs, rng):
        self.seen.append((np.array(obs.cameras["front"].rgb, copy=True), float(rng.random())))

    def act(self, obs):
        raise EpisodeFailure("no_actions", "test policy: looked only")


def _look(sim, seed, scene_seed):
    policy = FirstLook()
    result = run_episode(sim, policy, "phone_on_base", seed, 3, max_steps=1, scene_seed=scene_seed)
    assert result.seed == seed and result.error_kind == "no_actions"
    return policy.seen[0]


def test_the_same_scene_under_every_seed_while_the_policy_stream_follows_the_seed(sim):
    (pic0, draw0), (pic1, draw1) = _look(sim, 0, 0), _look(sim, 1, 0)
    assert np.array_equal(pic0, pic1) and draw0 != draw1
    pic1_own, draw1_own = _look(sim, 1, None)  # today's default: seed 1 draws its own scene
    assert not np.array_equal(pic0, pic1_own) and draw1_own == draw1


def test_scene_seed_is_checked_by_the_config_schema():
    import pytest

    from xicm.core.assembly.config_schema import Benchmark
    from xicm.core.contracts.errors import ConfigError
    from xicm.core.contracts.schema import check_options

    base = {"name": "b", "tasks": ["close_jar"], "pool": "p", "pool_tasks": ["close_jar"], "variations": "sampled",
            "instructions": "agnostos"}
    for ok in (None, 0, 7):
        check_options({**base, "scene_seed": ok}, Benchmark, prefix="benchmark", owner="benchmark")
    with pytest.raises(ConfigError, match="scene_seed"):
        check_options({**base, "scene_seed": -1}, Benchmark, prefix="benchmark", owner="benchmark")


def test_scene_seed_is_part_of_the_run_identity():
    from xicm.core.results.run_dir import identity

    ids = [identity({"seeds": [0, 1], "benchmark": {"name": "agnostos", "scene_seed": s}}) for s in (None, 0)]
    assert ids[0]["benchmark.scene_seed"] is None and ids[1]["benchmark.scene_seed"] == 0
