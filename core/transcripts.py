"""Per-episode LLM transcripts: every prompt and reply of one episode in its own JSON file,
`<run_dir>/transcripts/<task>/s<seed>-e<episode:04d>.json`, so episodes.jsonl rows stay small
(they keep the replies and the first prompt's hash)."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

TRANSCRIPTS_DIR = "transcripts"


def transcript_path(run_dir: Path, task: str, seed: int, episode: int) -> Path:
    return Path(run_dir) / TRANSCRIPTS_DIR / task / f"s{int(seed)}-e{int(episode):04d}.json"


def write_transcript(run_dir: Path, task: str, seed: int, episode: int, calls: list[dict[str, Any]]) -> dict[str, str]:
    """Write the calls ({"messages": [...], "reply": "..."} each) atomically; return what goes into
    the row's extra: the file relative to the run folder, or why it could not be written."""
    path = transcript_path(run_dir, task, seed, episode)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".tmp")
        data = {"task": task, "seed": int(seed), "episode": int(episode), "calls": calls}
        tmp.write_text(json.dumps(data, indent=1, ensure_ascii=False, default=str), encoding="utf-8")
        os.replace(tmp, path)
    except Exception as exc:  # noqa: BLE001 - a transcript must not fail the episode
        return {"transcript_error": f"{type(exc).__name__}: {exc}"[:300]}
    return {"transcript": path.relative_to(run_dir).as_posix()}
