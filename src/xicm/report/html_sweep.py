"""sweep.html: one self-contained page over several runs (a multirun): success against each
swept key with Wilson 95 % intervals (one line per value of the other keys) and the table of
runs, each linked to its own report.html when it has one."""

from __future__ import annotations

import datetime as _dt
import os
from pathlib import Path
from typing import Any

from xicm.core.results.atomic import write_atomic
from xicm.core.results.run_dir import RunDir
from xicm.report import figures, table2
from xicm.report.html_run import REPORT_HTML, render
from xicm.report.sweep import sortable, collect_sweep, group_names

SWEEP_HTML = "sweep.html"
PLOT_GROUP = "All"  # the group each axis plot shows; the table has every group


def _intervals(run: Path, groups: list[str]) -> dict[str, dict[str, Any]]:
    """Per group: pooled n, successes and Wilson interval of the run's episodes."""
    meta = RunDir(run).read_meta()
    rows = RunDir(run).rows(meta)
    splits = meta["splits"]
    out = {}
    for group in groups:
        split = None if group == "All" else group.lower().replace("-", "")
        members = [r for r in rows if split is None or splits.get(r["task"]) == split]
        if members:
            out[group] = table2.pooled(members)
    return out


def axis_lines(sweep: dict[str, Any], axis: str) -> dict[str, list[tuple[Any, float, float, float]]]:
    """{label of the other keys' values: [(axis value, mean, ci_low, ci_high), ...]} for PLOT_GROUP."""
    others = [a for a in sweep["axes"] if a != axis]
    lines: dict[str, list] = {}
    for row in sweep["rows"]:
        if PLOT_GROUP not in row["groups"] or PLOT_GROUP not in row["pooled"]:
            continue
        label = ", ".join(f"{k}={row[k]}" for k in others)
        pooled = row["pooled"][PLOT_GROUP]
        lines.setdefault(label, []).append((row[axis], row["groups"][PLOT_GROUP][0], pooled["ci_low"], pooled["ci_high"]))
    for points in lines.values():
        points.sort(key=lambda p: sortable(p[0]))
    return lines


def sweep_context(root: Path, runs: list[Path]) -> dict[str, Any]:
    sweep = collect_sweep(runs)
    groups = group_names(sweep)
    for row in sweep["rows"]:
        run = Path(row["run"])
        row["pooled"] = _intervals(run, groups)
        page = run / REPORT_HTML
        row["link"] = os.path.relpath(page, root) if page.is_file() else None
        row["label"] = os.path.relpath(run, root)
    plots = []
    for axis in sweep["axes"]:
        xs = sorted({row[axis] for row in sweep["rows"]}, key=sortable)
        plots.append({"axis": axis, "svg": figures.sweep_axis(axis_lines(sweep, axis), axis, xs, PLOT_GROUP)})
    return {
        "title": f"xicm sweep: {Path(root).resolve().name}",
        "root": str(root),
        "generated": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "sweep": sweep,
        "groups": groups,
        "plots": plots,
        "plot_group": PLOT_GROUP,
    }


def write_sweep_html(root: Path, runs: list[Path]) -> Path:
    """Write <root>/sweep.html and return its path."""
    path = Path(root) / SWEEP_HTML
    write_atomic(path, render("sweep.html.j2", sweep_context(Path(root), runs)))
    return path
