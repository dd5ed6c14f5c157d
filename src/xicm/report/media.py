"""What the HTML report embeds from a run: rollout videos (inline under a size cap, else a
relative link), the first frames of retrieved pool demos, and LLM transcripts."""

from __future__ import annotations

import base64
import io
import json
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from xicm.core.results.dataset import first_frames

MB = 1024 * 1024
THUMB_PIXELS = 96  # retrieved demos' first frames, longest side
TRANSCRIPT_CHARS = 20_000  # per episode; the rest stays in the linked file


def data_uri(mime: str, data: bytes) -> str:
    return f"data:{mime};base64,{base64.b64encode(data).decode('ascii')}"


@dataclass
class VideoBudget:
    """Inline a video only if it is at most `per_video` bytes and the page's total stays under `total`."""

    per_video: int
    total: int
    used: int = 0
    linked: list[str] = field(default_factory=list)

    def source(self, run_dir: Path, rel: str) -> dict[str, Any] | None:
        """{'src', 'inline', 'bytes', 'path'} for a video the row names, or None if the file is gone."""
        path = Path(run_dir) / rel
        if not path.is_file():
            return None
        size = path.stat().st_size
        if size <= self.per_video and self.used + size <= self.total:
            self.used += size
            return {"src": data_uri("video/mp4", path.read_bytes()), "inline": True, "bytes": size, "path": rel}
        self.linked.append(rel)
        return {"src": rel, "inline": False, "bytes": size, "path": rel}


def pool_candidates(pool_path: str | None, run_dir: Path) -> list[Path]:
    """Where a run's pool may be: as recorded (absolute, or relative to where the report runs),
    then relative to the run folder and the folders above it (the run's working directory)."""
    if not pool_path:
        return []
    path = Path(pool_path)
    if path.is_absolute():
        return [path]
    run_dir = Path(run_dir).resolve()
    return [path, *(base / path for base in (run_dir, *run_dir.parents[:3]))]


def demo_thumbnails(pool_path: str | None, run_dir: Path, demo_ids: Iterable[str]) -> tuple[dict[str, str], str]:
    """{demo id: PNG data URI of its first frame} and a sentence saying where they came from
    (or why there are none). Never raises: a report without pictures beats no report."""
    wanted = sorted(set(demo_ids))
    if not wanted:
        return {}, "no demos were retrieved in this run"
    found = next((p for p in pool_candidates(pool_path, run_dir) if p.is_file()), None)
    if found is None:
        return {}, f"the demonstration pool {pool_path!r} is not reachable from here; first frames are not shown (pass --pool PATH)"
    try:
        from PIL import Image

        out = {}
        for demo, frame in first_frames(found, wanted).items():
            image = Image.fromarray(frame)
            image.thumbnail((THUMB_PIXELS, THUMB_PIXELS))
            buf = io.BytesIO()
            image.save(buf, format="PNG", optimize=True)
            out[demo] = data_uri("image/png", buf.getvalue())
    except Exception as exc:  # noqa: BLE001 - a broken pool only costs the pictures
        return {}, f"the demonstration pool {found} could not be read ({type(exc).__name__}: {exc}); first frames are not shown"
    missing = len(wanted) - len(out)
    note = f"first frames from {found}" + (f"; {missing} retrieved demos have none there" if missing else "")
    return out, note


def transcript(run_dir: Path, rel: str | None, limit: int = TRANSCRIPT_CHARS) -> dict[str, Any] | None:
    """{'path', 'calls': [{'messages': [{'role', 'content'}], 'reply'}], 'cut': bool} with at most
    `limit` characters of text in all; None when the episode has no readable transcript."""
    if not rel:
        return None
    path = Path(run_dir) / rel
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    left, calls, cut = limit, [], False
    for call in data.get("calls", []):
        messages = []
        for message in call.get("messages", []):
            content = str(message.get("content", ""))
            if len(content) > left:
                content, cut = content[:left], True
            left -= len(content)
            messages.append({"role": message.get("role", "?"), "content": content})
        reply = str(call.get("reply", ""))
        if len(reply) > left:
            reply, cut = reply[:left], True
        left -= len(reply)
        calls.append({"messages": messages, "reply": reply})
        if left <= 0:
            cut = cut or len(calls) < len(data.get("calls", []))
            break
    return {"path": rel, "calls": calls, "cut": cut}
