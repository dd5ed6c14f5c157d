"""X-ICM's own per-episode logs (src/xicm/report/xicm_logs.yaml, transcribed from its repository): per-task
success over its seeds, which gives the paper rows of the Table-2 layout their per-task cells, and
how its episodes end (success, early end, all 25 key actions), to set beside ours."""

from __future__ import annotations

import functools
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

XICM_LOGS = Path(__file__).with_name("xicm_logs.yaml")
MAX_STEPS = 25  # upstream's key-action budget per episode (its config.yaml); "Step" never exceeds it


@functools.lru_cache(maxsize=1)
def _data() -> dict[str, Any]:
    import yaml

    return yaml.safe_load(XICM_LOGS.read_text(encoding="utf-8"))


def source() -> dict[str, str]:
    """{'repo', 'commit'} the numbers were read from."""
    return dict(_data()["source"])


def runs() -> dict[str, dict[str, Any]]:
    """Each logged run by the name of the paper_table2.yaml row it belongs to."""
    return {run["row"]: run for run in _data()["runs"]}


def parse_episodes(text: str) -> tuple[list[tuple[int, bool]], str]:
    """'25 9 7+ … | 4.0,22.76,569' -> ([(25, False), (9, False), (7, True), …], '4.0,22.76,569')."""
    body, sep, footer = str(text).partition("|")
    if not sep:
        raise ValueError(f"X-ICM log entry {text[:40]!r} has no '|' before the csv footer")
    episodes = []
    for token in body.split():
        digits = token[:-1] if token.endswith("+") else token
        if not digits.isdigit() or not 1 <= int(digits) <= MAX_STEPS:
            raise ValueError(f"X-ICM log token {token!r} is not a step count 1..{MAX_STEPS} with an optional '+'")
        episodes.append((int(digits), token.endswith("+")))
    return episodes, footer.strip()


def task_success(run: dict[str, Any]) -> dict[str, dict[str, float]]:
    """Per task: mean and std (ddof 0, as upstream's gather_score prints) over the run's seeds, in percent."""
    out = {}
    for task, per_seed in run["scores"].items():
        values = np.asarray(per_seed, float)
        out[task] = {"mean": float(values.mean()), "std": float(values.std()), "seeds": int(values.size)}
    return out


def level_means(run: dict[str, Any], levels: dict[str, list[str]]) -> dict[str, float]:
    """Per level (e.g. {'level1': [...], 'level2': [...]}): mean over seeds of the mean over the
    level's tasks, the way upstream and the paper average."""
    return {name: float(np.mean([np.mean([run["scores"][t][i] for t in tasks]) for i in range(len(run["seeds"]))]))
            for name, tasks in levels.items()}


def summarise_ends(episodes: Iterable[tuple[int, bool]]) -> dict[str, float]:
    """(steps, success) pairs -> episodes, successes, failures that ended early (before the 25th key
    action: an error ended them), failures that used all 25, and mean steps. The same rule for
    upstream's csvs and for our rows, so the two compare."""
    episodes = list(episodes)
    steps = [s for s, _ in episodes]
    return {
        "episodes": len(episodes),
        "successes": sum(ok for _, ok in episodes),
        "early": sum(not ok and s < MAX_STEPS for s, ok in episodes),
        "full": sum(not ok and s >= MAX_STEPS for s, ok in episodes),
        "mean_steps": float(np.mean(steps)) if steps else float("nan"),
    }


def seed_episodes(per_seed: dict[int, str | None]) -> Iterator[tuple[int, bool]]:
    """(steps, success) of every transcribed episode of one task, seed after seed."""
    for text in per_seed.values():
        if text is not None:
            yield from parse_episodes(text)[0]


def episode_ends(run: dict[str, Any]) -> dict[str, dict[str, float]]:
    """summarise_ends per task, over the seeds whose csv the repository keeps."""
    return {task: summarise_ends(seed_episodes(per_seed)) for task, per_seed in run["episodes"].items()}


def run_ends(run: dict[str, Any]) -> dict[str, float]:
    """summarise_ends over all of a run's transcribed episodes."""
    return summarise_ends(e for per_seed in run["episodes"].values() for e in seed_episodes(per_seed))
