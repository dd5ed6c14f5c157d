"""Merge runs of the same experiment that cover different tasks (or seeds) into one report.

For runs sharded by task list, e.g. tasks run on several machines or a task added later:
`xicm-report --merge OUT DIR [DIR ...]` checks that the runs' configs agree except for
`benchmark.tasks`, `seeds` and `episodes` (and the keys outside a run's identity,
src/xicm/core/results/run_dir.py), concatenates their episodes (the same (task, seed, episode) twice is an
error) and writes OUT/episodes.jsonl, OUT/run.json (listing the sources), summary.json,
table.md and tasks.csv.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from xicm.core.results.atomic import write_atomic, write_json_atomic
from xicm.core.contracts.errors import XicmError
from xicm.core.results.run_dir import EPISODES, META, MERGE_MAY_DIFFER, RunDir, flatten, outside_identity
from xicm.report.summary import std_ddof, write_report


def merge_runs(out_dir: Path, run_dirs: list[Path]) -> dict[str, Any]:
    runs = [RunDir(r) for r in run_dirs]
    for run in runs:
        if not run.is_run():
            raise XicmError(f"{run.path} has no {EPISODES} and {META}; pass xicm-eval output folders")
    metas = [run.read_meta() for run in runs]
    first = flatten(metas[0].get("config", {}))
    for run, meta in zip(runs[1:], metas[1:]):
        other = flatten(meta.get("config", {}))
        differ = sorted(
            k for k in set(first) | set(other) if first.get(k) != other.get(k) and not outside_identity(k, MERGE_MAY_DIFFER)
        )
        if differ:
            raise XicmError(f"{run.path} was run with another config than {runs[0].path} ({', '.join(differ[:5])}); not merged")
    tasks: list[str] = []
    splits: dict[str, str] = {}
    rows: list[dict[str, Any]] = []
    seen: dict[tuple, Path] = {}
    for run, meta in zip(runs, metas):
        tasks += [t for t in meta["tasks"] if t not in tasks]
        splits.update(meta["splits"])
        for row in run.rows(meta):
            key = (row["task"], int(row["seed"]), int(row["episode"]))
            if key in seen:
                raise XicmError(f"episode {key} is in both {seen[key]} and {run.path}; not merged")
            seen[key] = run.path
            rows.append(row)
    out = RunDir(out_dir)
    out.path.mkdir(parents=True, exist_ok=True)
    write_atomic(out.episodes, "".join(json.dumps(r) + "\n" for r in rows))
    config = dict(metas[0].get("config", {}))
    if "seeds" in config:  # the merged run covers every source's seeds and episodes
        config["seeds"] = sorted({int(s) for m in metas for s in m.get("config", {}).get("seeds", [])})
    if "episodes" in config:
        config["episodes"] = max(int(m.get("config", {}).get("episodes", 0)) for m in metas)
    merged = {**metas[0], "config": config, "tasks": tasks, "splits": splits, "merged_from": [str(r) for r in run_dirs]}
    merged.pop("fingerprint", None)  # a merged folder is a report, not a run to resume
    write_json_atomic(out.meta, merged)
    return write_report(rows, splits, tasks, out.path, std_ddof(metas[0]))
