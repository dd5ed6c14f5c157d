"""Leave-one-task-out retrieval on the seen pool: for each seen task, which tasks the top-K
demos retrieved for its queries come from, under several retrievers.

The queries are the pool's held-out demos of the dynamics model (episode % heldout_every ==
heldout_every - 1; the model never trained on them, though it trained on other demos of the
same task). Demos of the query's own task are excluded (`exclude_same_task`), as they would be
for an unseen task. Also prints seconds per query feature for each retriever.

    python benchmarks/retrieval_loto.py                     # data/pools/seen.h5, data/dynamics/seen
    python benchmarks/retrieval_loto.py --k 18 --json out.json --retrievers dynamics,language,random
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from collections import Counter
from pathlib import Path

import numpy as np

from xicm.core.dataset import load_pool
from xicm.core.plugins import get_registry
from xicm.core.types import Query

ENCODER = {"dynamics": "dynamics", "dynamics_onepass": "dynamics", "language": "minilm", "random": None}
RETRIEVER = {"dynamics": "dynamics", "dynamics_onepass": "dynamics", "language": "similarity", "random": "random"}


def build(name: str, checkpoint: str, cache_dir: str, steps: int):
    registry = get_registry()
    encoder = None
    if ENCODER[name] == "dynamics":
        mode = "unet_features" if name == "dynamics_onepass" else "predicted_frame"
        encoder = registry.create("encoder", {"name": "dynamics", "checkpoint": checkpoint, "mode": mode, "steps": steps})
    elif ENCODER[name]:
        encoder = registry.create("encoder", {"name": ENCODER[name]})
    options = {"name": RETRIEVER[name], "exclude_same_task": True}
    if name != "random":
        options["cache_dir"] = cache_dir
    return registry.create("retriever", options, encoder=encoder)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pool", default="data/pools/seen.h5")
    ap.add_argument("--checkpoint", default="data/dynamics/seen")
    ap.add_argument("--retrievers", default="dynamics,dynamics_onepass,language,random")
    ap.add_argument("--k", type=int, default=18)
    ap.add_argument("--steps", type=int, default=10, help="DDIM steps of the predicted-frame feature")
    ap.add_argument("--heldout-every", type=int, default=20)
    ap.add_argument("--queries-per-task", type=int, default=3)
    ap.add_argument("--cache-dir", default=str(Path.home() / ".cache/xicm/features"))
    ap.add_argument("--json", default=None, help="write every figure here")
    args = ap.parse_args()

    pool = load_pool(args.pool)
    queries = [d for d in pool if d.episode % args.heldout_every == args.heldout_every - 1]
    per_task: dict[str, list] = {}
    for d in queries:
        per_task.setdefault(d.task, [])
        if len(per_task[d.task]) < args.queries_per_task:
            per_task[d.task].append(d)
    tasks = sorted(per_task)
    results: dict[str, dict] = {}
    for name in args.retrievers.split(","):
        retriever = build(name, args.checkpoint, args.cache_dir, args.steps)
        started = time.perf_counter()
        retriever.prepare(pool)
        prepare_s = time.perf_counter() - started
        rng = np.random.default_rng(0)
        seconds, rows = [], {}
        for task in tasks:
            counts: Counter = Counter()
            for demo in per_task[task]:
                query = Query(task=demo.task, instruction=demo.instruction, objects=demo.objects, front_rgb=demo.first_rgb)
                t0 = time.perf_counter()
                chosen = retriever.select(query, pool, args.k, rng)
                seconds.append(time.perf_counter() - t0)
                counts.update(d.task for d, _ in chosen)
            total = sum(counts.values())
            rows[task] = {t: round(100.0 * c / total, 1) for t, c in counts.most_common()}
        results[name] = {
            "prepare_seconds": round(prepare_s, 2),
            "cache_hit": getattr(retriever, "cache_hit", None),
            "seconds_per_query_median": round(statistics.median(seconds), 4),
            "sources": rows,
        }
        print(f"\n## {name}: pool features {prepare_s:.1f} s (cache hit: {results[name]['cache_hit']}), "
              f"median {results[name]['seconds_per_query_median'] * 1000:.1f} ms per query (k={args.k})")
        print("| held-out task | top source tasks (% of retrieved demos) | distinct tasks |")
        print("|---|---|---|")
        for task in tasks:
            top = ", ".join(f"{t} {p:g}" for t, p in list(rows[task].items())[:3])
            print(f"| {task} | {top} | {len(rows[task])} |")
    if args.json:
        Path(args.json).write_text(json.dumps({"k": args.k, "queries_per_task": args.queries_per_task, "results": results}, indent=2))


if __name__ == "__main__":
    main()
