"""The paper's Table 2 layout: the 23 unseen AGNOSTOS tasks as columns (paper order), then
Level-1 / Level-2 / All; our run's row beside the paper's published rows (src/xicm/report/paper_table2.yaml),
which come from another simulator and are always labelled with their source. The X-ICM rows take
their per-task cells from X-ICM's own logs (src/xicm/report/xicm_logs.yaml)."""

from __future__ import annotations

import functools
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from xicm.report import xicm_logs
from xicm.report.summary import summarise, wilson_interval

PAPER_TABLE = Path(__file__).with_name("paper_table2.yaml")
LEVELS = ("Level-1", "Level-2", "All")


@functools.lru_cache(maxsize=1)
def paper_table() -> dict[str, Any]:
    """{'source', 'citation', 'level1', 'level2', 'rows': [{'name', 'level1', 'level2', 'all', 'all_std',
    'tasks', 'task_notes'}]}; a row with logs in src/xicm/report/xicm_logs.yaml gets its per-task means from them
    and a note per cell (seeds, std, source)."""
    import yaml

    table = yaml.safe_load(PAPER_TABLE.read_text(encoding="utf-8"))
    logged, src = xicm_logs.runs(), xicm_logs.source()
    for row in table["rows"]:
        row.setdefault("tasks", {})
        row["task_notes"] = {}
        if row["name"] in logged:
            ends = xicm_logs.episode_ends(logged[row["name"]])
            for task, s in xicm_logs.task_success(logged[row["name"]]).items():
                e = ends[task]
                row["tasks"][task] = round(s["mean"], 2)
                row["task_notes"][task] = (
                    f"{task}: mean of {s['seeds']} seeds (std {s['std']:.1f}); of {e['episodes']} episodes "
                    f"{100 * e['early'] / e['episodes']:.0f} % failed early, {100 * e['full'] / e['episodes']:.0f} % "
                    f"used all 25 key actions, mean {e['mean_steps']:.1f} key actions; X-ICM's logs, {src['repo']} at {src['commit'][:7]}")
    return table


def columns() -> list[str]:
    table = paper_table()
    return [*table["level1"], *table["level2"]]


def pooled(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Episodes, successes and the Wilson 95 % interval (percent) of the rows taken together."""
    n, k = len(rows), sum(bool(r["success"]) for r in rows)
    lo, hi = wilson_interval(k, n)
    return {"n": n, "successes": k, "ci_low": 100 * lo, "ci_high": 100 * hi}


def our_row(rows: Sequence[dict[str, Any]], name: str, ddof: int = 1) -> dict[str, Any]:
    """Our run in the Table-2 layout: per column task its summary row (absent when not run),
    per level mean (std over seeds), seeds, and the pooled n and Wilson interval.
    Levels are the paper's (its two task lists), so 'All' never includes seen tasks."""
    table = paper_table()
    cols = columns()
    splits = {**{t: "level1" for t in table["level1"]}, **{t: "level2" for t in table["level2"]}}
    mine = [r for r in rows if r["task"] in splits]
    summary = summarise(mine, splits, cols, ddof)
    groups = {}
    for g in summary["groups"]:
        members = [r for r in mine if g["group"] == "All" or splits[r["task"]] == g["group"].lower().replace("-", "")]
        groups[g["group"]] = {**g, **pooled(members)}
    return {"name": name, "tasks": {r["task"]: r for r in summary["tasks"]}, "groups": groups, "episodes": len(mine)}


def flat_rows(ours: dict[str, Any], our_source: str) -> tuple[list[str], list[list[Any]]]:
    """Columns and rows of one plain table (wandb.Table, CSV): method, source, the 23 tasks,
    Level-1, Level-2, All, All std; None where a value is not known."""
    table = paper_table()
    cols = columns()
    head = ["method", "source", *cols, *LEVELS, "All std"]

    def level(name: str, key: str) -> Any:
        group = ours["groups"].get(name)
        return None if group is None else round(group[key], 2)

    data = [
        [
            ours["name"], our_source,
            *(round(ours["tasks"][t]["success"], 2) if t in ours["tasks"] else None for t in cols),
            *(level(name, "success") for name in LEVELS), level("All", "std"),
        ]
    ]
    for row in table["rows"]:
        data.append(
            [row["name"], table["source"], *(row["tasks"].get(t) for t in cols), row["level1"], row["level2"], row["all"], row["all_std"]]
        )
    return head, data
