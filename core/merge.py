"""Merge runs of the same experiment that cover different tasks (or seeds) into one report.

For runs sharded by task list, e.g. tasks run on several machines or a task added later:
`xicm-report --merge OUT DIR [DIR ...]` checks that the runs' configs agree except for
`benchmark.tasks`, `seeds` and `episodes` (and the keys a run may change when resumed), concatenates
their episodes (the same (task, seed, episode) twice is an error) and writes OUT/episodes.jsonl,
OUT/run.json (listing the sources), summary.json, table.md and tasks.csv.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from xicm.core.errors import XicmError
from xicm.core.evaluate import EPISODES_FILE, run_rows, write_json_atomic, write_text_atomic

MAY_DIFFER = ("benchmark.tasks", "seeds", "episodes", "paths.", "run_name", "tracking.", "progress", "llm_cache.", "collect.", "shards.",
              "video.", "transcripts")


def merge_runs(out_dir: Path, run_dirs: list[Path]) -> dict[str, Any]:
    from xicm.core.eval_job import write_report
    from xicm.core.sweep import flatten

    metas = []
    for run in run_dirs:
        if not (run / "run.json").exists() or not (run / EPISODES_FILE).exists():
            raise XicmError(f"{run} has no {EPISODES_FILE} and run.json; pass xicm-eval output folders")
        metas.append(json.loads((run / "run.json").read_text()))
    first = flatten(metas[0].get("config", {}))
    for run, meta in zip(run_dirs[1:], metas[1:]):
        other = flatten(meta.get("config", {}))
        differ = sorted(
            k for k in set(first) | set(other) if first.get(k) != other.get(k) and not k.startswith(MAY_DIFFER)
        )
        if differ:
            raise XicmError(f"{run} was run with another config than {run_dirs[0]} ({', '.join(differ[:5])}); not merged")
    tasks: list[str] = []
    splits: dict[str, str] = {}
    rows: list[dict[str, Any]] = []
    seen: dict[tuple, Path] = {}
    for run, meta in zip(run_dirs, metas):
        tasks += [t for t in meta["tasks"] if t not in tasks]
        splits.update(meta["splits"])
        for row in run_rows(run, meta):
            key = (row["task"], int(row["seed"]), int(row["episode"]))
            if key in seen:
                raise XicmError(f"episode {key} is in both {seen[key]} and {run}; not merged")
            seen[key] = run
            rows.append(row)
    out_dir.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out_dir / EPISODES_FILE, "".join(json.dumps(r) + "\n" for r in rows))
    config = dict(metas[0].get("config", {}))
    if "seeds" in config:  # the merged run covers every source's seeds and episodes
        config["seeds"] = sorted({int(s) for m in metas for s in m.get("config", {}).get("seeds", [])})
    if "episodes" in config:
        config["episodes"] = max(int(m.get("config", {}).get("episodes", 0)) for m in metas)
    merged = {**metas[0], "config": config, "tasks": tasks, "splits": splits, "merged_from": [str(r) for r in run_dirs]}
    merged.pop("fingerprint", None)  # a merged folder is a report, not a run to resume
    write_json_atomic(out_dir / "run.json", merged)
    return write_report(rows, splits, tasks, out_dir)
