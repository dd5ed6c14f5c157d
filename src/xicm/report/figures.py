"""The HTML report's figures as inline SVG strings (matplotlib, Agg; text stays text)."""

from __future__ import annotations

import io
from collections.abc import Sequence
from typing import Any

from xicm.report import require

SPLIT_COLOURS = {"level1": "#4C72B0", "level2": "#DD8452", "seen": "#55A868"}
OTHER_COLOUR = "#8C8C8C"


def _svg(fig, name: str) -> str:
    """The figure as an <svg> element; `name` salts matplotlib's ids so figures on one page never share one."""
    plt = pyplot()
    buf = io.StringIO()
    with plt.rc_context({"svg.fonttype": "none", "svg.hashsalt": name}):
        fig.savefig(buf, format="svg", bbox_inches="tight")
    plt.close(fig)
    text = buf.getvalue()
    return text[text.index("<svg") :]


def pyplot():
    """matplotlib.pyplot on the Agg backend (no display), or ReportExtraMissing."""
    require("matplotlib", "a report figure").use("Agg")
    return require("matplotlib.pyplot", "a report figure")


def _height(rows: int) -> float:
    return 1.0 + 0.28 * max(rows, 1)


def task_success(task_rows: Sequence[dict[str, Any]]) -> str:
    """One horizontal bar per task: success % (mean over seeds), whiskers = Wilson 95 % interval."""
    plt = pyplot()
    rows = list(task_rows)[::-1]
    fig, ax = plt.subplots(figsize=(7, _height(len(rows))), dpi=100)
    y = range(len(rows))
    mean = [r["success"] for r in rows]
    err = [[max(m - r["ci_low"], 0) for m, r in zip(mean, rows)], [max(r["ci_high"] - m, 0) for m, r in zip(mean, rows)]]
    ax.barh(y, mean, color=[SPLIT_COLOURS.get(r["split"], OTHER_COLOUR) for r in rows], xerr=err, capsize=3, ecolor="#333")
    ax.set_yticks(list(y), [f"{r['task']} (n={r['n']})" for r in rows], fontsize=8)
    ax.set_xlim(0, 100)
    ax.set_xlabel("success % (bar: mean over seeds; whiskers: Wilson 95 % interval)")
    handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in SPLIT_COLOURS.values()]
    ax.legend(handles, list(SPLIT_COLOURS), fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.grid(axis="x", alpha=0.3)
    return _svg(fig, "task-success")


def _stacked(rows: Sequence[tuple[str, dict[str, float]]], xlabel: str, name: str, colours: dict[str, str] | None = None) -> str:
    plt = pyplot()
    rows = list(rows)[::-1]
    keys: list[str] = []
    for _, parts in rows:
        keys += [k for k in parts if k not in keys]
    fig, ax = plt.subplots(figsize=(7, _height(len(rows))), dpi=100)
    left = [0.0] * len(rows)
    cmap = plt.get_cmap("tab10")
    for i, key in enumerate(keys):
        values = [parts.get(key, 0.0) for _, parts in rows]
        colour = (colours or {}).get(key, cmap(i % 10))
        ax.barh(range(len(rows)), values, left=left, label=key, color=colour)
        left = [a + b for a, b in zip(left, values)]
    ax.set_yticks(range(len(rows)), [label for label, _ in rows], fontsize=8)
    ax.set_xlabel(xlabel)
    if keys:
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.grid(axis="x", alpha=0.3)
    return _svg(fig, name)


def error_kinds(task_rows: Sequence[dict[str, Any]]) -> str:
    """Episodes per task stacked by outcome: successes, then each error kind."""
    rows = [(r["task"], {"success": float(r["successes"]), **{k: float(v) for k, v in sorted(r["errors"].items())}}) for r in task_rows]
    return _stacked(rows, "episodes (success, or how the episode ended)", "error-kinds", {"success": "#55A868"})


def stage_seconds(per_task: Sequence[tuple[str, dict[str, float]]]) -> str:
    """Mean seconds per episode per task, stacked by stage (reset, detect, llm, execute, ...)."""
    rows = [(task, {k: v for k, v in stages.items() if k != "total"}) for task, stages in per_task]
    return _stacked(rows, "seconds per episode, by stage", "stage-seconds")


def level_bars(ours: Sequence[tuple[str, dict[str, float]]], paper: Sequence[tuple[str, dict[str, float]]]) -> str:
    """Level-1 / Level-2 / All: our rows (solid, whiskers = Wilson 95 %) beside the paper's (hatched)."""
    plt = pyplot()
    levels = ("Level-1", "Level-2", "All")
    series = [(name, values, False) for name, values in ours] + [(name, values, True) for name, values in paper]
    width = 0.8 / max(len(series), 1)
    fig, ax = plt.subplots(figsize=(8, 3.6), dpi=100)
    cmap = plt.get_cmap("tab10")
    for i, (name, values, is_paper) in enumerate(series):
        xs = [j + (i - (len(series) - 1) / 2) * width for j in range(len(levels))]
        mean = [values.get(level, float("nan")) for level in levels]
        err = None
        if not is_paper:
            err = [[max(m - values.get(f"{lv} low", m), 0) for m, lv in zip(mean, levels)],
                   [max(values.get(f"{lv} high", m) - m, 0) for m, lv in zip(mean, levels)]]
        ax.bar(xs, mean, width, yerr=err, capsize=2, label=name + (" (paper, RLBench/CoppeliaSim)" if is_paper else ""),
               color=cmap(i % 10), hatch="//" if is_paper else None, edgecolor="white" if is_paper else None, alpha=0.6 if is_paper else 1.0)
    ax.set_xticks(range(len(levels)), levels)
    ax.set_ylabel("success %")
    ax.set_ylim(0, 100)
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return _svg(fig, "level-bars")


def sweep_axis(lines: dict[str, list[tuple[Any, float, float, float]]], axis: str, xs: Sequence[Any], group: str) -> str:
    """Success against one swept key: one line per value of the other keys; points
    (x, mean, ci_low, ci_high), whiskers = Wilson 95 % interval over the pooled episodes."""
    plt = pyplot()
    numeric = all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in xs)
    fig, ax = plt.subplots(figsize=(6.5, 3.8), dpi=100)
    # lines with equal values would hide each other: shift each a little sideways
    span = (max(xs) - min(xs) or 1) if numeric else len(xs)
    step = 0.012 * span if numeric else 0.04
    for i, (label, points) in enumerate(lines.items()):
        shift = (i - (len(lines) - 1) / 2) * step
        pos = [(p[0] if numeric else list(xs).index(p[0])) + shift for p in points]
        mean = [p[1] for p in points]
        err = [[max(m - p[2], 0) for m, p in zip(mean, points)], [max(p[3] - m, 0) for m, p in zip(mean, points)]]
        ax.errorbar(pos, mean, yerr=err, marker="o", capsize=3, label=label)
    if not numeric:
        ax.set_xticks(range(len(xs)), [str(x) for x in xs])
    ax.set_xlabel(axis)
    ax.set_ylabel(f"{group} success % (Wilson 95 %)")
    ax.set_ylim(-2, 102)
    ax.grid(alpha=0.3)
    if len(lines) > 1 or next(iter(lines), ""):
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return _svg(fig, f"sweep-{axis}")
