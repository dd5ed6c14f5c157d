import json

from xicm.core import evaluate
from xicm.core.types import EpisodeResult


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
    keys = evaluate.episode_keys(["a", "b"], [0, 1], 3)
    assert len(keys) == 12 and keys[0] == ("a", 0, 0) and keys[3] == ("b", 0, 0)
    first = Recorder(crash_at=("b", 0, 1))
    try:
        evaluate.run_episodes(first, keys, tmp_path, progress=False)
    except KeyboardInterrupt:
        pass
    assert len(first.calls) == 4
    second = Recorder()
    rows = evaluate.run_episodes(second, keys, tmp_path, progress=False)
    assert second.calls == keys[4:]
    assert len(rows) == 12
    lines = (tmp_path / evaluate.EPISODES_FILE).read_text().splitlines()
    assert len(lines) == 12 and len({(json.loads(l)["task"], json.loads(l)["seed"], json.loads(l)["episode"]) for l in lines}) == 12


def test_a_torn_last_line_is_dropped_and_redone(tmp_path):
    keys = evaluate.episode_keys(["a"], [0], 3)
    evaluate.run_episodes(Recorder(), keys[:2], tmp_path, progress=False)
    path = tmp_path / evaluate.EPISODES_FILE
    path.write_text(path.read_text() + '{"task": "a", "seed": 0, "epis')  # killed mid-write
    again = Recorder()
    rows = evaluate.run_episodes(again, keys, tmp_path, progress=False)
    assert again.calls == [("a", 0, 2)]
    assert [r["episode"] for r in rows] == [0, 1, 2]
    assert all(json.loads(l) for l in path.read_text().splitlines())


def test_atomic_json_write_leaves_no_temp_file(tmp_path):
    target = tmp_path / "summary.json"
    evaluate.write_json_atomic(target, {"x": 1})
    evaluate.write_json_atomic(target, {"x": 2})
    assert json.loads(target.read_text()) == {"x": 2}
    assert [p.name for p in tmp_path.iterdir()] == ["summary.json"]
