"""The outer loop: a run's (task, seed, episode) keys one after another into its episodes.jsonl.

Keys already there are skipped, so a killed or extended run resumes where it stopped. Each
key's episode is one `core.episode.run_episode`, wherever it runs (the dispatcher:
src/xicm/core/execution/episode_runner.py); the loop inside an episode is src/xicm/core/execution/episode.py's."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

from xicm.core.results.run_dir import RunDir
from xicm.core.contracts.types import EpisodeResult


def run_all_episodes(
    run_one: Callable[[str, int, int], EpisodeResult],
    keys: list[tuple[str, int, int]],
    out_dir: Path,
    progress: bool = True,
    on_result: Callable[[EpisodeResult], None] | None = None,
) -> list[dict[str, Any]]:
    """Run every key not already in out_dir's episodes.jsonl; return all rows for these keys."""
    run = RunDir(out_dir)
    with run.appending_episodes() as append:
        done = {(r["task"], r["seed"], r["episode"]): r for r in run.read_episodes()}
        todo = [k for k in keys if k not in done]
        bar = _progress(len(keys), initial=len(keys) - len(todo), enabled=progress)
        successes = sum(1 for k in keys if k in done and done[k]["success"])
        for task, seed, episode in todo:
            result = run_one(task, seed, episode)
            row = dataclasses.asdict(result)
            append(row)
            done[(task, seed, episode)] = row
            successes += int(result.success)
            if on_result is not None:
                on_result(result)
            if bar is not None:
                bar.update(1)
                bar.set_postfix_str(f"{task} s{seed} e{episode} success {successes}/{bar.n}")
    if bar is not None:
        bar.close()
    return [done[k] for k in keys]


def _progress(total: int, initial: int, enabled: bool):
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, desc="episodes", unit="ep", dynamic_ncols=True)
