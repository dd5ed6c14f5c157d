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
        cfg = compose("config", overrides=[f"llm={args.llm}", f"retriever={args.retriever}", f"prompt.k={args.k}", *args.overrides])

    from xicm.core import build
    from xicm.core.agent import XICMAgent
    from xicm.core.dataset import load_pool
    from xicm.core.plugins import get_registry

    reg = get_registry()
    t0 = time.perf_counter()
    sim = reg.create_simulator(build.options(cfg, "simulator"))
    t_sim = time.perf_counter() - t0
    pool = load_pool(build.check_pool(cfg.pool_path), tasks=list(cfg.benchmark.pool_tasks))
    retriever = build.build_retriever(cfg, reg, build.build_encoder(cfg, reg))
    t0 = time.perf_counter()
    retriever.prepare(pool)
    t_prepare = time.perf_counter() - t0
    t0 = time.perf_counter()
    llm = build.build_llm(cfg, reg)
    t_llm_load = time.perf_counter() - t0
    agent = XICMAgent(
        sim, reg.create("detector", build.options(cfg, "detector")), retriever,
        reg.create("prompt", build.options(cfg, "prompt")), llm, pool, k=args.k, max_steps=int(cfg.max_steps),
    )
    tasks = args.tasks.split(",")
    sim.reset(tasks[0], 0, 999)  # warm-up: the first render of a process compiles shaders
    results = [agent.run_episode(tasks[i % len(tasks)], 0, i) for i in range(args.episodes)]
    sim.close()

    print(f"simulator start {t_sim:.2f} s | retriever.prepare({len(pool)} demos) {t_prepare:.2f} s | LLM load {t_llm_load:.2f} s")
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
