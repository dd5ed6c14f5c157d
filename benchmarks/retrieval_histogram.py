"""Which seen tasks the demos of each unseen task come from, per selection: the top-K task
histogram of finished runs, read from their episodes (prints a table; not a test).

Each run's rows record the demos its first LLM call showed (`retrieved`, ids `task/s<seed>/e<n>`);
for every unseen task the script counts their tasks over the run's episodes and prints, per run,
the three most shown seen tasks with their share of all shown demos, the number of distinct seen
tasks shown, and the normalised entropy of the histogram (0: always one task; 1: all 18 alike,
what random selection tends to). Runs of the selection ablation differ only in the retriever, so
the columns compare selections on the same scenes.

    python benchmarks/retrieval_histogram.py results/agnostos/ablation-selection/*-nearest_demo
    python benchmarks/retrieval_histogram.py RUN... --json histogram.json   # the whole histograms too
"""

from __future__ import annotations

import argparse
import json
import math
from collections import Counter, defaultdict
from pathlib import Path

from xicm.core.results.run_dir import RunDir


def histograms(run: Path) -> dict[str, Counter]:
    """unseen task -> Counter of the seen tasks of its episodes' first-call demos."""
    out: dict[str, Counter] = defaultdict(Counter)
    for row in RunDir(run).rows():
        for demo_id in row.get("retrieved") or []:
            out[row["task"]][str(demo_id).split("/", 1)[0]] += 1
    return dict(out)


def entropy(counts: Counter, n_tasks: int) -> float:
    total = sum(counts.values())
    if total == 0 or n_tasks < 2:
        return 0.0
    h = -sum(c / total * math.log(c / total) for c in counts.values() if c)
    return max(0.0, h / math.log(n_tasks))  # max: -0.0 when one task holds every demo


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--top", type=int, default=3)
    parser.add_argument("--seen-tasks", type=int, default=18, help="the pool's task count (the entropy's scale)")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    per_run = {run.name: histograms(run) for run in args.runs}
    tasks = sorted({task for h in per_run.values() for task in h})
    for task in tasks:
        print(f"\n{task}")
        for name, h in per_run.items():
            counts = h.get(task, Counter())
            total = sum(counts.values()) or 1
            top = ", ".join(f"{t} {100 * c / total:.0f}%" for t, c in counts.most_common(args.top))
            print(f"  {name:40s} distinct {len(counts):2d}  entropy {entropy(counts, args.seen_tasks):.2f}  {top}")
    print("\nmean over unseen tasks: distinct seen tasks / normalised entropy")
    for name, h in per_run.items():
        if h:
            distinct = sum(len(c) for c in h.values()) / len(h)
            ent = sum(entropy(c, args.seen_tasks) for c in h.values()) / len(h)
            print(f"  {name:40s} {distinct:5.1f} / {ent:.2f}  ({len(h)} unseen tasks)")
    if args.json:
        args.json.write_text(json.dumps({name: {t: dict(c) for t, c in h.items()} for name, h in per_run.items()},
                                        indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
