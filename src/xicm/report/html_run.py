"""report.html: one self-contained page per run (no network; figures, thumbnails and small
videos inline). Sections: the paper's Table 2 with our row beside the published ones, per task
(success with intervals, error kinds, seconds per stage), per episode (retrieved demos with
their first frames, LLM transcript, rollout video)."""

from __future__ import annotations

import datetime as _dt
from collections import defaultdict
from pathlib import Path
from typing import Any

from xicm.core.results.atomic import write_atomic
from xicm.core.results.run_dir import RunDir
from xicm.report import figures, media, require, table2
from xicm.report.summary import stage_seconds, std_ddof, summarise

REPORT_HTML = "report.html"
INLINE_VIDEO_MB = 2.0  # per video; larger ones are linked (src/xicm/conf/config.yaml report.inline_video_mb)
INLINE_VIDEO_TOTAL_MB = 64  # all videos of one page together


def render(template: str, context: dict[str, Any]) -> str:
    jinja2 = require("jinja2", "an HTML report")
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(Path(__file__).with_name("templates"))),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    env.filters["pct"] = lambda v: "–" if v is None or v != v else f"{v:.1f}"
    env.filters["mb"] = lambda b: f"{b / media.MB:.2f} MB"
    return env.get_template(template).render(**context)


def _label(meta: dict[str, Any], run_dir: Path) -> str:
    return str((meta.get("config") or {}).get("run_name") or Path(run_dir).name)


def _episode_key(row: dict[str, Any]) -> tuple[int, int]:
    return int(row["seed"]), int(row["episode"])


def _episode(run_dir: Path, row: dict[str, Any], thumb_class: dict[str, str], budget: media.VideoBudget) -> dict[str, Any]:
    """What the page shows of one episode row: its demos, video and transcript."""
    extra = row.get("extra") or {}
    return {
        "row": row,
        "retrieved": [{"id": d, "thumb": thumb_class.get(d)} for d in row.get("retrieved") or []],
        "video": budget.source(run_dir, extra["video"]) if extra.get("video") else None,
        "video_error": extra.get("video_error"),
        "transcript": media.transcript(run_dir, extra.get("transcript")),
        "seconds": (row.get("timings") or {}).get("total"),
    }


def run_context(run_dir: Path, inline_video_mb: float = INLINE_VIDEO_MB, pool: str | None = None) -> dict[str, Any]:
    run = RunDir(run_dir)
    meta = run.read_meta()
    rows = run.rows(meta)
    config = meta.get("config") or {}
    summary = summarise(rows, meta["splits"], meta["tasks"], std_ddof(meta))
    label = _label(meta, run.path)
    simulator = (config.get("simulator") or {}).get("name", "?")
    ours = table2.our_row(rows, label, std_ddof(meta))
    paper = table2.paper_table()

    by_task: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        by_task[r["task"]].append(r)
    seconds = [(t["task"], stage_seconds(by_task[t["task"]])) for t in summary["tasks"]]

    thumbs, pool_note = media.demo_thumbnails(pool or config.get("pool_path"), run.path, (d for r in rows for d in r.get("retrieved") or []))
    thumb_class = {demo: f"d{i}" for i, demo in enumerate(sorted(thumbs))}
    budget = media.VideoBudget(int(inline_video_mb * media.MB), INLINE_VIDEO_TOTAL_MB * media.MB)
    episodes = [
        {"task": t, "rows": [_episode(run.path, r, thumb_class, budget) for r in sorted(by_task[t["task"]], key=_episode_key)]}
        for t in summary["tasks"]
    ]

    our_levels = {}
    for g, v in ours["groups"].items():
        our_levels.update({g: v["success"], f"{g} low": v["ci_low"], f"{g} high": v["ci_high"]})
    paper_levels = [(row["name"], {"Level-1": row["level1"], "Level-2": row["level2"], "All": row["all"]}) for row in paper["rows"]]
    return {
        "title": f"xicm report: {label}",
        "label": label,
        "run_dir": str(run.path),
        "generated": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "policy": meta.get("policy") or (config.get("policy") or {}).get("name", "?"),
        "simulator": simulator,
        "benchmark": (config.get("benchmark") or {}).get("name", "?"),
        "seeds": summary["seeds"],
        "episodes_per_seed": config.get("episodes"),
        "plugins": meta.get("plugins") or [],
        "summary": summary,
        "columns": [{"task": t, "level": "Level-1" if t in paper["level1"] else "Level-2"} for t in table2.columns()],
        "ours": ours,
        "our_source": f"ours, {simulator} (this run)",
        "paper": paper,
        "level_svg": figures.level_bars([(label, our_levels)], paper_levels) if ours["groups"] else None,
        "task_svg": figures.task_success(summary["tasks"]) if summary["tasks"] else None,
        "errors_svg": figures.error_kinds(summary["tasks"]) if summary["tasks"] else None,
        "stages_svg": figures.stage_seconds(seconds) if any(s for _, s in seconds) else None,
        "seconds": summary["seconds"],
        "task_seconds": {task: s["total"] for task, s in seconds if "total" in s},
        "episodes": episodes,
        "thumbs": [(thumb_class[d], uri) for d, uri in thumbs.items()],
        "pool_note": pool_note,
        "videos_inline": budget.used,
        "videos_linked": budget.linked,
        "inline_video_mb": inline_video_mb,
    }


def write_run_html(run_dir: Path, inline_video_mb: float = INLINE_VIDEO_MB, pool: str | None = None) -> Path:
    """Write <run_dir>/report.html and return its path."""
    path = Path(run_dir) / REPORT_HTML
    write_atomic(path, render("run.html.j2", run_context(run_dir, inline_video_mb, pool)))
    return path
