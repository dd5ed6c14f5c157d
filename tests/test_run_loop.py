"""The episode loop: episodes.jsonl grows by one fsynced row per episode, and a re-run
(after a kill, or with more keys) runs only the keys not in it."""

import json

from xicm.core.execution.run_loop import run_all_episodes
from xicm.core.results.run_dir import EPISODES, episode_keys
from xicm.core.contracts.types import EpisodeResult


class Recorder:
    """Counts calls; fails on purpose at one key to imitate a killed run."""

    def __init__(self, crash_at=None):
        self.calls = []
        self.crash_at = crash_at

    def __call__(self, task, seed, episode):
        if (task, seed, episode) == self.crash_at:
            raise KeyboardInterrupt
        self.calls.append((task, seed, episode))
        return EpisodeResult(task=task, seed=seed, episode=episode, success=episode % 2 == 0, steps=1)


def test_resume_skips_finished_episodes_and_loses_none(tmp_path):
    keys = episode_keys(["a", "b"], [0, 1], 3)
    assert len(keys) == 12 and keys[0] == ("a", 0, 0) and keys[3] == ("b", 0, 0)
    first = Recorder(crash_at=("b", 0, 1))
    try:
        run_all_episodes(first, keys, tmp_path, progress=False)
    except KeyboardInterrupt:
        pass
    assert len(first.calls) == 4
    second = Recorder()
    rows = run_all_episodes(second, keys, tmp_path, progress=False)
    assert second.calls == keys[4:]
    assert len(rows) == 12
    lines = (tmp_path / EPISODES).read_text().splitlines()
    assert len(lines) == 12 and len({(json.loads(l)["task"], json.loads(l)["seed"], json.loads(l)["episode"]) for l in lines}) == 12


def test_a_torn_last_line_is_dropped_and_redone(tmp_path):
    keys = episode_keys(["a"], [0], 3)
    run_all_episodes(Recorder(), keys[:2], tmp_path, progress=False)
    path = tmp_path / EPISODES
    path.write_text(path.read_text() + '{"task": "a", "seed": 0, "epis')  # killed mid-write
    again = Recorder()
    rows = run_all_episodes(again, keys, tmp_path, progress=False)
    assert again.calls == [("a", 0, 2)]
    assert [r["episode"] for r in rows] == [0, 1, 2]
    assert all(json.loads(l) for l in path.read_text().splitlines())
