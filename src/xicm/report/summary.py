"""Success tables: per task, then Level-1 / Level-2 / Seen / All as mean (std) over seeds."""

from __future__ import annotations

import csv
import io
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from xicm.core.results.atomic import write_atomic, write_json_atomic
from xicm.core.results.run_dir import TRANSCRIPTS, VIDEOS, RunDir, video_passed

GROUPS = (("Level-1", "level1"), ("Level-2", "level2"), ("Seen", "seen"))


def wilson_interval(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a success rate (0..1), z = 1.96 standard errors (95%) as the
    reports have always used: scipy's, at the confidence level 2*Phi(z) - 1 that z stands for."""
    if n == 0:
        return (0.0, 0.0)
    from scipy.stats import binomtest, norm  # scipy.stats takes ~0.5 s to import: only when reporting

    ci = binomtest(int(successes), int(n)).proportion_ci(confidence_level=2 * norm.cdf(z) - 1, method="wilson")
    return (float(ci.low), float(ci.high))


def std_ddof(meta: dict[str, Any]) -> int:
    """A run's std convention (run.json's config `report.std_ddof`; 1 for runs that predate it)."""
    return int(((meta.get("config") or {}).get("report") or {}).get("std_ddof", 1))


def _mean_std(values: Sequence[float], ddof: int = 1) -> tuple[float, float]:
    arr = np.asarray(values, float)
    if arr.size == 0:
        return (float("nan"), float("nan"))
    std = float(arr.std(ddof=ddof)) if arr.size > 1 else 0.0
    return (float(arr.mean()), std)


def summarise(
    rows: Sequence[dict[str, Any]], splits: dict[str, str], task_order: Sequence[str], ddof: int = 1
) -> dict[str, Any]:
    """Success rates (percent) per task and per group; seeds are the unit of the std (ddof 1: the
    sample std, ours; 0: numpy's default, X-ICM's gather_score.py)."""
    per_task_seed: dict[str, dict[int, list[bool]]] = defaultdict(lambda: defaultdict(list))
    errors: dict[str, dict[str, int]] = defaultdict(lambda: defaultdict(int))
    for r in rows:
        per_task_seed[r["task"]][int(r["seed"])].append(bool(r["success"]))
        if r.get("error_kind"):
            errors[r["task"]][r["error_kind"]] += 1
    seeds = sorted({int(r["seed"]) for r in rows})
    tasks = [t for t in task_order if t in per_task_seed]

    task_rows = []
    for task in tasks:
        by_seed = per_task_seed[task]
        rates = [100.0 * np.mean(by_seed[s]) for s in seeds if by_seed.get(s)]
        flat = [x for s in seeds for x in by_seed.get(s, [])]
        mean, std = _mean_std(rates, ddof)
        lo, hi = wilson_interval(sum(flat), len(flat))
        task_rows.append(
            {
                "task": task,
                "split": splits.get(task, "?"),
                "success": mean,
                "std": std,
                "n": len(flat),
                "successes": int(sum(flat)),
                "ci_low": 100 * lo,
                "ci_high": 100 * hi,
                "errors": dict(errors.get(task, {})),
            }
        )

    group_rows = []
    for label, split in (*GROUPS, ("All", None)):
        members = [t for t in tasks if split is None or splits.get(t) == split]
        if not members:
            continue
        seed_means = []
        for s in seeds:
            rates = [100.0 * np.mean(per_task_seed[t][s]) for t in members if per_task_seed[t].get(s)]
            if rates:
                seed_means.append(float(np.mean(rates)))
        mean, std = _mean_std(seed_means, ddof)
        group_rows.append({"group": label, "tasks": len(members), "success": mean, "std": std, "seeds": len(seed_means)})
    return {
        "seeds": seeds, "tasks": task_rows, "groups": group_rows, "episodes": len(rows), "seconds": stage_seconds(rows), "std_ddof": ddof,
    }


def stage_seconds(rows: Sequence[dict[str, Any]]) -> dict[str, float]:
    """Mean seconds per episode spent in each stage (reset, detect, retrieve, llm, execute, ...)."""
    totals: dict[str, float] = defaultdict(float)
    for r in rows:
        for stage, seconds in (r.get("timings") or {}).items():
            totals[stage] += float(seconds)
    return {stage: totals[stage] / len(rows) for stage in totals} if rows else {}


def markdown_table(summary: dict[str, Any]) -> str:
    one_seed = len(summary["seeds"]) < 2  # no spread to show

    def std(value: float) -> str:
        return "-" if one_seed else f"{value:.1f}"

    lines = [
        "| task | split | success % | std | n | 95% CI | errors |",
        "|---|---|---:|---:|---:|---|---|",
    ]
    for r in summary["tasks"]:
        errs = ", ".join(f"{k} {v}" for k, v in sorted(r["errors"].items())) or "-"
        lines.append(
            f"| {r['task']} | {r['split']} | {r['success']:.1f} | {std(r['std'])} | {r['n']} "
            f"| {r['ci_low']:.0f}-{r['ci_high']:.0f} | {errs} |"
        )
    for g in summary["groups"]:
        lines.append(f"| **{g['group']}** ({g['tasks']} tasks) | | **{g['success']:.1f}** | {std(g['std'])} | | | |")
    lines.append("")
    lines.append(f"{summary['episodes']} episodes, seeds {summary['seeds']}; std is over seeds.")
    seconds = summary.get("seconds") or {}
    if seconds:
        stages = ", ".join(f"{k} {v:.2f}" for k, v in seconds.items() if k != "total")
        lines.append(f"Seconds per episode: {stages}; total {seconds.get('total', 0.0):.2f}.")
    return "\n".join(lines)


def write_report(
    rows: list[dict[str, Any]], splits: dict[str, str], tasks: list[str], run_dir: Path, ddof: int = 1
) -> dict[str, Any]:
    """Summarise the rows and write the run folder's summary.json, table.md and tasks.csv."""
    run = RunDir(run_dir)
    summary = summarise(rows, splits, tasks, ddof)
    write_json_atomic(run.summary, summary)
    media = "".join("\n" + line for line in media_lines(rows, run.path))
    write_atomic(run.table, markdown_table(summary) + media + "\n")
    write_atomic(run.tasks_csv, tasks_csv(summary))
    return summary


def media_lines(rows: Sequence[dict[str, Any]], run_dir: Path, links_per_task: int = 4) -> list[str]:
    """Markdown lines naming the run's rollout videos (one line per task, failures linked first)
    and LLM transcripts; paths are relative to `run_dir`, where table.md lives. [] if none."""
    videos: dict[str, list[str]] = defaultdict(list)
    transcripts: dict[str, int] = defaultdict(int)
    video_errors = 0
    for r in rows:
        extra = r.get("extra") or {}
        if extra.get("video") and (Path(run_dir) / extra["video"]).is_file():
            videos[r["task"]].append(extra["video"])
        video_errors += bool(extra.get("video_error"))
        if extra.get("transcript") and (Path(run_dir) / extra["transcript"]).is_file():
            transcripts[r["task"]] += 1
    lines = []
    if videos or video_errors:
        lines += ["", f"Rollout videos ({VIDEOS}/<task>/s<seed>-e<episode>-PASS|FAIL.mp4):"]
        for task, paths in videos.items():
            passed = sum(map(video_passed, paths))
            shown = sorted(paths, key=lambda p: (video_passed(p), p))[:links_per_task]
            links = ", ".join(f"[{Path(p).stem}]({p})" for p in shown) + (", ..." if len(paths) > len(shown) else "")
            lines.append(f"- {task}: {len(paths)} ({passed} PASS, {len(paths) - passed} FAIL): {links}")
        if video_errors:
            lines.append(f"- {video_errors} episodes without a video (see extra.video_error in episodes.jsonl)")
    if transcripts:
        counts = ", ".join(f"{task} {n}" for task, n in transcripts.items())
        lines += ["", f"LLM prompts and replies ({TRANSCRIPTS}/<task>/s<seed>-e<episode>.json): {counts} episodes."]
    return lines


def tasks_csv(summary: dict[str, Any]) -> str:
    buf = io.StringIO()
    writer = csv.writer(buf)
    writer.writerow(["task", "split", "success_pct", "std_over_seeds", "n", "successes", "ci_low_pct", "ci_high_pct"])
    for r in summary["tasks"]:
        writer.writerow([r["task"], r["split"], f"{r['success']:.2f}", f"{r['std']:.2f}", r["n"], r["successes"], f"{r['ci_low']:.2f}", f"{r['ci_high']:.2f}"])
    for g in summary["groups"]:
        writer.writerow([g["group"], "group", f"{g['success']:.2f}", f"{g['std']:.2f}", "", "", "", ""])
    return buf.getvalue()
