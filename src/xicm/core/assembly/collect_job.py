"""xicm-collect's job: scripted demonstrations of benchmark.pool_tasks into pool_path."""

from __future__ import annotations

import os
import time
from pathlib import Path

from omegaconf import DictConfig

from xicm.core.assembly import checks
from xicm.core.contracts.errors import ConfigError
from xicm.core.assembly.plugins import get_registry


def run_collect(cfg: DictConfig) -> dict[str, tuple[int, int]]:
    tasks = list(cfg.benchmark.pool_tasks)
    if not tasks:
        raise ConfigError(f"benchmark '{cfg.benchmark.name}' lists no pool_tasks to collect")
    checks.run_checks(checks.COLLECT, cfg, get_registry(), tasks)

    from xicm.core.execution.collect import build_collector, collect, collect_parallel, collector_config

    out_path = Path(cfg.pool_path)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    workers = resolve_workers(cfg.collect.workers)
    common = dict(
        tasks=tasks,
        demos_per_task=int(cfg.collect.demos_per_task),
        seed=int(cfg.collect.seed),
        out_path=out_path,
        max_attempts_factor=float(cfg.collect.max_attempts_factor),
        progress=bool(cfg.progress),
    )
    start = time.perf_counter()
    if workers == 1:
        simulator, detector = build_collector(cfg)
        try:
            counts = collect(simulator=simulator, detector=detector, **common)
        finally:
            simulator.close()
    else:
        counts = collect_parallel(collector_config(cfg), workers=workers, **common)
    seconds = time.perf_counter() - start
    print(f"\npool: {out_path}  ({workers} worker{'s' if workers > 1 else ''}, {seconds:.0f} s)")
    print("| task | demos | attempts | scripted success % |\n|---|---:|---:|---:|")
    for task, (ok, attempts) in counts.items():
        print(f"| {task} | {ok} | {attempts} | {100.0 * ok / max(attempts, 1):.1f} |")
    return counts


def resolve_workers(value) -> int:
    """collect.workers (checked by the schema): a positive number, or 'auto' (one per CPU core)."""
    return max(1, os.cpu_count() or 1) if value == "auto" else int(value)
