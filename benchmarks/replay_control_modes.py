"""Replaying scripted demonstrations recorded at the control rate, in each per-step control mode.

For every task and episode: reset (the collection seed), record the scripted solution with
`record_scripted` (physics only), then reset the same episode and step the recording's actions
(`control_modes.actions`) in each of ee_delta, ee_pose, joint_pos, joint_delta until success.
Only demonstrations the scripted solution itself solved are replayed.

    python benchmarks/replay_control_modes.py [--demos 5] [--tasks open_drawer ...] [--split seen]
"""

from __future__ import annotations

import argparse
import time


def main() -> None:
    from xicm.core.assembly.plugins import get_registry
    from xicm.plugins.simulators.sapien.options import CONTROL_MODES
    from xicm.plugins.simulators.sapien.replay import replay_steps

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--demos", type=int, default=5, help="episodes 0..N-1 per task")
    parser.add_argument("--seed", type=int, default=10000, help="the collection seed (conf: collect.seed)")
    parser.add_argument("--tasks", nargs="*", default=None, help="tasks (default: every task of --split)")
    parser.add_argument("--split", default="seen", help="seen, level1, level2 or all")
    args = parser.parse_args()

    registry = get_registry()
    sim = registry.create_simulator({"name": "sapien", "render": False})
    tasks = args.tasks or [t for t in sim.task_names() if args.split == "all" or sim.task_info(t).split == args.split]
    totals = {m: 0 for m in CONTROL_MODES}
    recorded = 0
    print(f"{'task':<28} {'demos':>5} " + " ".join(f"{m:>11}" for m in CONTROL_MODES) + f" {'steps':>6} {'s':>6}")
    for task in tasks:
        ok = {m: 0 for m in CONTROL_MODES}
        n, steps, t0 = 0, [], time.perf_counter()
        for episode in range(args.demos):
            sim.reset_state(task, args.seed, episode)
            rec = sim.record_scripted()
            if not rec.success:
                continue
            n += 1
            steps.append(rec.steps)
            for mode in CONTROL_MODES:
                success, error = replay_steps(sim, rec, mode)
                ok[mode] += int(success)
                if not success:
                    print(f"  {task} e{episode} {mode}: failed{': ' + error if error else ''}")
        recorded += n
        for m in CONTROL_MODES:
            totals[m] += ok[m]
        mean = sum(steps) / len(steps) if steps else 0.0
        print(f"{task:<28} {n:>5} " + " ".join(f"{ok[m]:>11}" for m in CONTROL_MODES) + f" {mean:>6.1f} {time.perf_counter() - t0:>6.1f}", flush=True)
    print(f"{'all':<28} {recorded:>5} " + " ".join(f"{100 * totals[m] / max(recorded, 1):>10.1f}%" for m in CONTROL_MODES))
    sim.close()


if __name__ == "__main__":
    main()
