"""Seconds per stage of one X-ICM episode (median over episodes), on the real simulator.

    python benchmarks/bench_episode.py --llm nearest_demo --episodes 6
    python benchmarks/bench_episode.py --llm gemma3_270m --episodes 2 --k 2

Needs a pool (xicm-collect benchmark=smoke). Prints one row per stage.
"""

from __future__ import annotations

import argparse
import statistics
import time

from hydra import compose, initialize_config_module


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--llm", default="nearest_demo")
    ap.add_argument("--retriever", default="language")
    ap.add_argument("--k", type=int, default=2)
    ap.add_argument("--episodes", type=int, default=6)
    ap.add_argument("--tasks", default="open_drawer,push_buttons,close_microwave")
    ap.add_argument("overrides", nargs="*", help="extra Hydra overrides")
    args = ap.parse_args()

    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        cfg = compose("config", overrides=[f"llm={args.llm}", f"retriever={args.retriever}", f"policy.k={args.k}", *args.overrides])

    from xicm.core.assembly.build import build_run
    from xicm.core.execution.episode import run_episode

    t0 = time.perf_counter()
    run = build_run(cfg)  # the simulator, then the policy: pool, retriever features, LLM load
    t_build = time.perf_counter() - t0
    tasks = args.tasks.split(",")
    run.simulator.reset(tasks[0], 0, 999)  # warm-up: the first render of a process compiles shaders
    results = [
        run_episode(run.simulator, run.policy, tasks[i % len(tasks)], 0, i, int(cfg.max_steps)) for i in range(args.episodes)
    ]
    metadata = run.metadata()
    run.close()

    print(f"build_run (simulator + policy over {metadata.get('pool_size')} pool demos) {t_build:.2f} s")
    print(f"{args.episodes} episodes, llm={args.llm}, retriever={args.retriever}, k={args.k}; success {sum(r.success for r in results)}/{len(results)}")
    stages = sorted({s for r in results for s in r.timings}, key=lambda s: (s == "total", s))
    print("| stage | median s/episode | max s |\n|---|---:|---:|")
    for s in stages:
        vals = [r.timings.get(s, 0.0) for r in results]
        print(f"| {s} | {statistics.median(vals):.3f} | {max(vals):.3f} |")
    steps = [r.steps for r in results]
    print(f"key actions per episode: median {statistics.median(steps)}; execute per action: "
          f"{sum(r.timings.get('execute', 0) for r in results) / max(sum(steps), 1):.3f} s")


if __name__ == "__main__":
    main()
