"""Demonstration-pool collection speed: 1 worker vs N worker processes, side by side.

    python benchmarks/bench_collect.py [--demos-per-task 5] [--workers 2] [--repeats 2]

Collects `demos-per-task` demos of every seen task into fresh pool files, alternating the
in-process collector and the parallel one, and prints the median demos per second (worker
start-up included), demos per second per core, and the time the full AGNOSTOS pool (200 per
seen task, 3,600 demos) would take at that rate.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

FULL_POOL = 3600


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--demos-per-task", type=int, default=5)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 2)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--tasks", nargs="*", default=None, help="default: the 18 seen tasks")
    args = ap.parse_args()

    from hydra import compose, initialize_config_module
    from xicm.core.execution.collect import build_collector, collect, collect_parallel, collector_config
    from xicm.core.assembly.plugins import get_registry

    registry = get_registry()
    tasks = args.tasks or [t for t in registry.names("task") if registry.task_info(t).split == "seen"]
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        cfg = compose("config")  # the default simulator and detector, as xicm-collect builds them
    simulator, detector = build_collector(cfg)  # the in-process collector keeps one alive, as one worker does
    simulator.reset(tasks[0], 0, 999)  # first render compiles shaders (each worker pays this too)

    rates: dict[int, list[float]] = {1: [], args.workers: []}
    with tempfile.TemporaryDirectory() as tmp:
        for rep in range(args.repeats):
            for workers in rates:
                path = Path(tmp) / f"pool-{workers}-{rep}.h5"
                start = time.perf_counter()
                if workers == 1:
                    counts = collect(simulator, detector, tasks, args.demos_per_task, 10_000 + rep, path, progress=False)
                else:
                    counts = collect_parallel(
                        collector_config(cfg), tasks, args.demos_per_task, 10_000 + rep, path, workers, progress=False
                    )
                seconds = time.perf_counter() - start
                demos = sum(ok for ok, _ in counts.values())
                rates[workers].append(demos / seconds)
                print(f"run {rep}: {workers} worker(s): {demos} demos in {seconds:.1f} s = {demos / seconds:.2f} demos/s")
    simulator.close()

    print(f"\n{len(tasks)} tasks x {args.demos_per_task} demos, median of {args.repeats} runs, {os.cpu_count()} cores")
    print("| workers | demos/s | demos/s per worker | full 3,600-demo pool |\n|---:|---:|---:|---:|")
    for workers, values in rates.items():
        rate = statistics.median(values)
        print(f"| {workers} | {rate:.2f} | {rate / workers:.2f} | {FULL_POOL / rate / 60:.0f} min |")
    base = statistics.median(rates[1])
    print(f"speed-up with {args.workers} workers: {statistics.median(rates[args.workers]) / base:.2f}x")


if __name__ == "__main__":
    main()
