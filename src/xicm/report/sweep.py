"""One report over many runs (a Hydra multirun, or any folders of xicm-eval outputs).

The config keys whose values differ between the runs are the sweep's axes (e.g.
`detector.noise_cm`, `policy.k`, `retriever.name`; never a key outside a run's identity, see
src/xicm/core/results/run_dir.py). For every run: those values and its
Level-1 / Level-2 / Seen / All success, mean (std over seeds). Written as sweep.md,
sweep.csv and sweep.json, and sweep.png: success against the first axis, one line per group
(or, with several axes, one line per combination of the others), error bars = std over seeds.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path
from typing import Any

from xicm.core.results.atomic import write_atomic, write_json_atomic
from xicm.core.results.run_dir import RunDir, flatten, outside_identity
from xicm.report import figures
from xicm.report.summary import std_ddof, summarise

SWEEP_FILES = ("sweep.md", "sweep.csv", "sweep.json", "sweep.png")  # written in the folder above the runs


def recorded_overrides(run: Path) -> dict[str, Any] | None:
    """{key: value} of the overrides Hydra recorded in a finished job's folder, or None."""
    path = RunDir(run).hydra_overrides
    if not path.exists():
        return None
    import yaml

    out: dict[str, Any] = {}
    for item in yaml.safe_load(path.read_text()) or []:
        key, _, value = str(item).partition("=")
        parsed = yaml.safe_load(value) if value else value
        # a list or dict value (e.g. seeds=[0]) stays the text given: axis values must be hashable
        out[key.lstrip("+~")] = value if isinstance(parsed, (list, dict)) else parsed
    return out


def varying(values: list[dict[str, Any]]) -> list[str]:
    keys = sorted({k for v in values for k in v})
    return [
        k for k in keys
        if not outside_identity(k) and len({json.dumps(v.get(k), default=str) for v in values}) > 1
    ]


def collect_sweep(runs: list[Path]) -> dict[str, Any]:
    """{'axes': [...], 'rows': [{axis values..., 'groups': {name: (mean, std, seeds)}, 'episodes': n, 'run': path}]}

    Axes are the overrides that differ between the jobs of a Hydra multirun (e.g. `retriever`,
    `policy.k`); for runs without Hydra's record, the config keys whose values differ.
    """
    metas = [RunDir(r).read_meta() for r in runs]
    overrides = [recorded_overrides(r) for r in runs]
    if all(o is not None for o in overrides):
        flats = overrides
    else:
        flats = [flatten(m.get("config", {})) for m in metas]
    axes = varying(flats)
    rows = []
    for run, meta, flat in zip(runs, metas, flats):
        summary = summarise(RunDir(run).rows(meta), meta["splits"], meta["tasks"], std_ddof(meta))
        rows.append(
            {
                **{a: flat.get(a) for a in axes},
                "groups": {g["group"]: (g["success"], g["std"], g["seeds"]) for g in summary["groups"]},
                "episodes": summary["episodes"],
                "run": str(run),
            }
        )
    rows.sort(key=lambda r: [sortable(r[a]) for a in axes])
    return {"axes": axes, "rows": rows}


def sortable(value):
    return (0, float(value), "") if isinstance(value, (int, float)) and not isinstance(value, bool) else (1, 0.0, str(value))


def group_names(sweep: dict[str, Any]) -> list[str]:
    seen = []
    for row in sweep["rows"]:
        seen += [g for g in row["groups"] if g not in seen]
    return seen


def sweep_markdown(sweep: dict[str, Any]) -> str:
    groups = group_names(sweep)
    head = [*sweep["axes"], *(f"{g} %" for g in groups), "episodes"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for row in sweep["rows"]:
        cells = [str(row[a]) for a in sweep["axes"]]
        for g in groups:
            mean, std, seeds = row["groups"].get(g, (None, None, 0))
            cells.append("-" if mean is None else f"{mean:.1f}" + (f" ({std:.1f})" if seeds > 1 else ""))
        cells.append(str(row["episodes"]))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n\nSuccess %: mean (std over seeds) over the group's tasks.\n"


def sweep_csv(sweep: dict[str, Any]) -> str:
    groups = group_names(sweep)
    buf = io.StringIO()
    out = csv.writer(buf)
    out.writerow([*sweep["axes"], *(f"{g}_{s}" for g in groups for s in ("mean", "std")), "episodes", "run"])
    for row in sweep["rows"]:
        values = []
        for g in groups:
            mean, std, _ = row["groups"].get(g, (None, None, 0))
            values += ["" if mean is None else f"{mean:.2f}", "" if std is None else f"{std:.2f}"]
        out.writerow([*(row[a] for a in sweep["axes"]), *values, row["episodes"], row["run"]])
    return buf.getvalue()


def sweep_plot(sweep: dict[str, Any], path: Path) -> Path | None:
    """success vs the first axis; None when there is no axis to plot against."""
    if not sweep["axes"]:
        return None
    plt = figures.pyplot()
    x_key, others = sweep["axes"][0], sweep["axes"][1:]
    groups = group_names(sweep)
    lines: dict[str, list[tuple[Any, float, float]]] = {}
    for row in sweep["rows"]:
        for g in groups if not others else ["All"]:
            if g not in row["groups"]:
                continue
            label = g if not others else ", ".join(f"{k}={row[k]}" for k in others)
            mean, std, _ = row["groups"][g]
            lines.setdefault(label, []).append((row[x_key], mean, std))
    xs = sorted({row[x_key] for row in sweep["rows"]}, key=sortable)
    numeric = all(sortable(x)[0] == 0 for x in xs)
    fig, ax = plt.subplots(figsize=(6, 4), dpi=120)
    for label, points in lines.items():
        points.sort(key=lambda p: sortable(p[0]))
        pos = [p[0] if numeric else xs.index(p[0]) for p in points]
        ax.errorbar(pos, [p[1] for p in points], yerr=[p[2] for p in points], marker="o", capsize=3, label=label)
    if not numeric:
        ax.set_xticks(range(len(xs)), [str(x) for x in xs])
    ax.set_xlabel(x_key)
    ax.set_ylabel("success %" + ("" if not others else " (All)"))
    ax.set_ylim(-2, 102)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def write_sweep(root: Path, runs: list[Path]) -> dict[str, Any]:
    sweep = collect_sweep(runs)
    md, csv_file, json_file, png = (Path(root) / name for name in SWEEP_FILES)
    write_atomic(md, sweep_markdown(sweep))
    write_atomic(csv_file, sweep_csv(sweep))
    write_json_atomic(json_file, sweep)
    sweep_plot(sweep, png)
    return sweep
