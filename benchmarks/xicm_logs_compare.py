"""Per task: X-ICM's own logs (src/xicm/report/xicm_logs.yaml, RLBench) beside our run folders (SAPIEN):
success, and how failed episodes end (early, before the 25th key action, or after all 25).
Prints the markdown table of docs/AGNOSTOS.md ("X-ICM's own logs beside our rows").

A task is named "easier here" when the first run's Wilson 95 % interval lies above the 72B mean
over its seeds, "harder here" when it lies below.

    python benchmarks/xicm_logs_compare.py results/agnostos/xicm-paper-language-k4-actions/nearest_demo \\
        results/agnostos/xicm-paper-language-k4-actions/qwen2_5_coder_0_5b
"""

from __future__ import annotations

import argparse
from collections import Counter, defaultdict
from pathlib import Path

from xicm.report import table2, xicm_logs
from xicm.report.summary import wilson_interval
from xicm.core.results.run_dir import RunDir


def pct(k: float, n: float) -> str:
    return f"{100 * k / n:.0f}" if n else "–"


def ends_cell(e: dict[str, float]) -> str:
    """'early % / full % · mean steps' of all episodes."""
    return f"{pct(e['early'], e['episodes'])} / {pct(e['full'], e['episodes'])} · {e['mean_steps']:.1f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path, help="our run folders (episodes.jsonl + run.json); the first decides the verdict")
    args = ap.parse_args()
    logged = xicm_logs.runs()
    big, small = logged["X-ICM (72B)"], logged["X-ICM (7B)"]
    success = {name: xicm_logs.task_success(run) for name, run in logged.items()}
    upstream_ends = xicm_logs.episode_ends(big)
    ours = []
    for folder in args.runs:
        run = RunDir(folder)
        if not run.is_run():
            ap.error(f"{folder} is not a run folder: it needs episodes.jsonl and run.json")
        by_task = defaultdict(list)
        for r in run.rows():
            by_task[r["task"]].append(r)
        ours.append((folder.name, by_task))

    names = [name for name, _ in ours]
    print("| task | L | 72B % | 7B % | " + " | ".join(f"{n} % (k/n)" for n in names)
          + " | verdict | 72B fails early / full % · steps | " + " | ".join(f"{n} early / full % · steps" for n in names) + " |")
    print("|---|---|" + "---:|" * (2 + len(names)) + "---|" + "---:|" * (1 + len(names)))
    totals = [Counter() for _ in ours]
    for task in table2.columns():
        level = "1" if task in table2.paper_table()["level1"] else "2"
        cells, ends, verdict = [], [], ""
        for i, (_, by_task) in enumerate(ours):
            rows = by_task.get(task, [])
            e = xicm_logs.summarise_ends((int(r["steps"]), bool(r["success"])) for r in rows)
            totals[i].update({k: e[k] for k in ("episodes", "successes", "early", "full")})
            totals[i]["steps"] += e["mean_steps"] * e["episodes"] if rows else 0
            cells.append(f"{pct(e['successes'], e['episodes'])} ({e['successes']}/{e['episodes']})")
            ends.append(ends_cell(e) if rows else "–")
            if i == 0 and rows:
                lo, hi = (100 * x for x in wilson_interval(e["successes"], e["episodes"]))
                mean = success["X-ICM (72B)"][task]["mean"]
                verdict = "easier here" if lo > mean else "harder here" if hi < mean else ""
        print(f"| {task} | {level} | {success['X-ICM (72B)'][task]['mean']:.1f} | {success['X-ICM (7B)'][task]['mean']:.1f} | "
              + " | ".join(cells) + f" | {verdict} | {ends_cell(upstream_ends[task])} | " + " | ".join(ends) + " |")
    all_up, all_small = xicm_logs.run_ends(big), xicm_logs.run_ends(small)
    mine = []
    for t in totals:
        t_ends = {**t, "mean_steps": t["steps"] / t["episodes"] if t["episodes"] else float("nan")}
        mine.append((f"{pct(t['successes'], t['episodes'])} ({t['successes']}/{t['episodes']})", ends_cell(t_ends)))
    print(f"| **all episodes** | | {pct(all_up['successes'], all_up['episodes'])} | "
          f"{pct(all_small['successes'], all_small['episodes'])} | " + " | ".join(m[0] for m in mine) + f" | | {ends_cell(all_up)} | "
          + " | ".join(m[1] for m in mine) + " |")


if __name__ == "__main__":
    main()
