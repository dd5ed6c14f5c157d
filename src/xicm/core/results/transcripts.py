"""Per-episode LLM transcripts: every prompt and reply of one episode in its own JSON file
(`RunDir.transcript`: transcripts/<task>/s<seed>-e<episode:04d>.json), so episodes.jsonl rows
stay small (they keep the replies and the first prompt's hash)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from xicm.core.results.atomic import write_json_atomic
from xicm.core.results.run_dir import RunDir


def write_transcript(run_dir: Path, task: str, seed: int, episode: int, calls: list[dict[str, Any]]) -> dict[str, str]:
    """Write the calls ({"messages": [...], "reply": "..."} each) atomically; return what goes into
    the row's extra: the file relative to the run folder, or why it could not be written."""
    run = RunDir(run_dir)
    path = run.transcript(task, seed, episode)
    try:
        data = {"task": task, "seed": int(seed), "episode": int(episode), "calls": calls}
        write_json_atomic(path, data, indent=1)
    except Exception as exc:  # noqa: BLE001 - a transcript must not fail the episode
        return {"transcript_error": f"{type(exc).__name__}: {exc}"[:300]}
    return {"transcript": run.relative(path)}
