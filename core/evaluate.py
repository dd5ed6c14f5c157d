"""Run episodes into an append-only episodes.jsonl, resuming where an earlier run stopped."""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from xicm.core.types import EpisodeResult

EPISODES_FILE = "episodes.jsonl"


def episode_keys(tasks: Iterable[str], seeds: Iterable[int], episodes: int) -> list[tuple[str, int, int]]:
    """Every (task, seed, episode) of a run, seed-major so partial runs cover all tasks."""
    return [(task, int(seed), ep) for seed in seeds for task in tasks for ep in range(int(episodes))]


def read_episodes(path: Path) -> list[dict[str, Any]]:
    """Complete lines of an episodes file; a torn last line (killed mid-write) is dropped."""
    if not path.exists():
        return []
    rows = []
    for line in path.read_text(encoding="utf-8").splitlines():
        line = line.strip()
        if not line:
            continue
        try:
            rows.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return rows


def run_rows(run_dir: Path, meta: dict[str, Any]) -> list[dict[str, Any]]:
    """The episodes of a run that its config asks for (run.json's tasks, seeds and episodes).

    An episodes file can hold more: a run resumed with fewer episodes or seeds keeps the rows of
    the earlier, larger one. Reports count only the configured ones, as xicm-eval did.
    """
    rows = read_episodes(Path(run_dir) / EPISODES_FILE)
    config = meta.get("config") or {}
    if "seeds" not in config or "episodes" not in config:
        return rows
    keys = set(episode_keys(meta["tasks"], config["seeds"], config["episodes"]))
    return [r for r in rows if (r["task"], int(r["seed"]), int(r["episode"])) in keys]


def _repair_torn_tail(path: Path) -> None:
    """Cut a partial last line so the next append starts on a fresh line."""
    if not path.exists() or path.stat().st_size == 0:
        return
    data = path.read_bytes()
    if data.endswith(b"\n"):
        return
    cut = data.rfind(b"\n") + 1
    with open(path, "r+b") as f:
        f.truncate(cut)


def run_episodes(
    run_episode: Callable[[str, int, int], EpisodeResult],
    keys: list[tuple[str, int, int]],
    out_dir: Path,
    progress: bool = True,
    on_result: Callable[[EpisodeResult], None] | None = None,
) -> list[dict[str, Any]]:
    """Run every key not already in out_dir/episodes.jsonl; return all rows for these keys."""
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / EPISODES_FILE
    _repair_torn_tail(path)
    done = {(r["task"], r["seed"], r["episode"]): r for r in read_episodes(path)}
    todo = [k for k in keys if k not in done]
    bar = _progress(len(keys), initial=len(keys) - len(todo), enabled=progress)
    successes = sum(1 for k in keys if k in done and done[k]["success"])
    with open(path, "a", encoding="utf-8") as f:
        for task, seed, episode in todo:
            result = run_episode(task, seed, episode)
            row = dataclasses.asdict(result)
            f.write(json.dumps(row, ensure_ascii=False) + "\n")
            f.flush()
            os.fsync(f.fileno())
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


def write_json_atomic(path: Path, data: Any) -> None:
    """Write JSON to a temp file beside `path`, then rename over it."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=2, ensure_ascii=False, default=str), encoding="utf-8")
    os.replace(tmp, path)


def write_text_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)
