"""Length of the scripted demonstrations in control steps (simulator.control_hz), per task.

For every task: record the scripted solution at the control rate (`record_scripted`, physics
only) for episodes 0..N-1 of a few seeds and print the median and longest length in control
steps, and ceil(2 x longest): the per-task default budget of per-step policies
(Task.max_control_steps, docs/DESIGN.md).

    python benchmarks/demo_lengths.py [--seeds 0 1 2] [--episodes 2] [--tasks open_drawer ...]
"""

from __future__ import annotations

import argparse
import math
import statistics


def main() -> None:
    from xicm.core.assembly.plugins import get_registry

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 10000])
    parser.add_argument("--episodes", type=int, default=2, help="episodes 0..N-1 per seed")
    parser.add_argument("--tasks", nargs="*", default=None, help="tasks (default: all)")
    args = parser.parse_args()

    sim = get_registry().create_simulator({"name": "sapien", "render": False})
    tasks = args.tasks or sim.task_names()
    print(f"{'task':<32} {'split':<7} {'demos':>5} {'failed':>6} {'median':>6} {'max':>5} {'2 x max':>7} {'declared':>8}")
    for task in tasks:
        lengths, failed = [], 0
        for seed in args.seeds:
            for episode in range(args.episodes):
                sim.reset_state(task, seed, episode)
                rec = sim.record_scripted()
                lengths.append(rec.steps)
                failed += int(not rec.success)
        info = sim.task_info(task)
        print(
            f"{task:<32} {info.split:<7} {len(lengths):>5} {failed:>6} {statistics.median(lengths):>6.0f} {max(lengths):>5}"
            f" {math.ceil(2 * max(lengths)):>7} {info.max_control_steps!s:>8}",
            flush=True,
        )
    sim.close()


if __name__ == "__main__":
    main()
