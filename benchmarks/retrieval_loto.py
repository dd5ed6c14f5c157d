"""Leave-one-task-out retrieval on the seen pool: for each seen task, which tasks the top-K
demos retrieved for its queries come from, under several retrievers.

The queries are the pool's held-out demos of the dynamics model (episode % heldout_every ==
heldout_every - 1; the model never trained on them, though it trained on other demos of the
same task). Demos of the query's own task are excluded (`exclude_same_task`), as they would be
for an unseen task. Also prints seconds per query feature for each retriever, and two measures
of how alike the retrieved demos' *real* dynamics are to the query's (means over queries and
retrieved demos; random is the floor):
- gripper pattern match: % of retrieved demos whose key actions open/close the gripper in the
  same sequence as the query's own demo (what the LLM copies from its examples);
- change cosine: cosine between the real change images (last minus first front frame, 32×32)
  of the query and a retrieved demo.

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

from xicm.core.results.dataset import load_pool
from xicm.core.assembly.plugins import get_registry
from xicm.core.contracts.types import Demo, Query
from xicm.plugins.dynamics.images import to_model

# retriever name -> dynamics encoder options (None: not a dynamics retriever)
DYNAMICS = {
    "dynamics": {"mode": "predicted_frame", "visual": "final"},
    "dynamics_change": {"mode": "predicted_frame", "visual": "change"},
    "dynamics_onepass": {"mode": "unet_features"},
    # X-ICM's ranking (src/xicm/conf/retriever/dynamics_xicm.yaml): the raw predicted final frame, no text, dot product
    "dynamics_xicm": {"mode": "predicted_frame", "visual": "final", "text_weight": 0.0, "normalise": False},
}
SCORE = {"dynamics_xicm": "dot"}  # retriever.score where it is not cosine


def build(name: str, checkpoint: str, cache_dir: str, steps: int, text_weight: float):
    registry = get_registry()
    options: dict = {"exclude_same_task": True, "cache_dir": cache_dir}
    if name in DYNAMICS:
        spec = {"name": "dynamics", "checkpoint": checkpoint, "steps": steps, "text_weight": text_weight, **DYNAMICS[name]}
        retriever = {"name": "dynamics", **options, "score": SCORE.get(name, "cosine")}
        return registry.create("retriever", retriever, encoder=registry.create("encoder", spec))
    if name == "language":
        return registry.create("retriever", {"name": "similarity", **options}, encoder=registry.create("encoder", {"name": "minilm"}))
    if name == "random":
        return registry.create("retriever", {"name": "random", "exclude_same_task": True})
    raise SystemExit(f"unknown retriever '{name}'; choose from {', '.join([*DYNAMICS, 'language', 'random'])}")


def gripper_pattern(demo: Demo) -> tuple[bool, ...]:
    return tuple(a.gripper_open for a in demo.key_actions)


def real_changes(pool: list[Demo]) -> dict[str, np.ndarray]:
    """demo id -> unit-length real change image (last - first frame at 32x32), flattened."""
    first = to_model([d.first_rgb for d in pool], 32)
    last = to_model([d.last_rgb for d in pool], 32)
    change = (last - first).flatten(1).numpy()
    change /= np.maximum(np.linalg.norm(change, axis=1, keepdims=True), 1e-8)
    return {d.demo_id: change[i] for i, d in enumerate(pool)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pool", default="data/pools/seen.h5")
    ap.add_argument("--checkpoint", default="data/dynamics/seen")
    ap.add_argument("--retrievers", default="dynamics,dynamics_change,dynamics_onepass,dynamics_xicm,language,random")
    ap.add_argument("--k", type=int, default=18)
    ap.add_argument("--steps", type=int, default=1, help="DDIM steps of the predicted-frame features (the encoder default: 1)")
    ap.add_argument("--text-weight", type=float, default=0.5, help="share of the text cosine in dynamics similarity")
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
    changes = real_changes(pool)
    results: dict[str, dict] = {}
    for name in args.retrievers.split(","):
        retriever = build(name, args.checkpoint, args.cache_dir, args.steps, args.text_weight)
        started = time.perf_counter()
        retriever.prepare(pool)
        prepare_s = time.perf_counter() - started
        rng = np.random.default_rng(0)
        seconds, rows, pattern_match, change_cos = [], {}, [], []
        for task in tasks:
            counts: Counter = Counter()
            for demo in per_task[task]:
                query = Query(task=demo.task, instruction=demo.instruction, objects=demo.objects, front_rgb=demo.first_rgb)
                t0 = time.perf_counter()
                chosen = retriever.select(query, pool, args.k, rng)
                seconds.append(time.perf_counter() - t0)
                counts.update(d.task for d, _ in chosen)
                pattern_match.append(np.mean([gripper_pattern(d) == gripper_pattern(demo) for d, _ in chosen]))
                change_cos.append(np.mean([float(changes[d.demo_id] @ changes[demo.demo_id]) for d, _ in chosen]))
            total = sum(counts.values())
            rows[task] = {t: round(100.0 * c / total, 1) for t, c in counts.most_common()}
        results[name] = {
            "prepare_seconds": round(prepare_s, 2),
            "cache_hit": getattr(retriever, "cache_hit", None),
            "seconds_per_query_median": round(statistics.median(seconds), 4),
            "gripper_pattern_match_percent": round(100.0 * float(np.mean(pattern_match)), 1),
            "change_cosine": round(float(np.mean(change_cos)), 3),
            "change_cosine_sem": round(float(np.std(change_cos, ddof=1) / np.sqrt(len(change_cos))), 3),
            "sources": rows,
        }
        print(f"\n## {name}: pool features {prepare_s:.1f} s (cache hit: {results[name]['cache_hit']}), "
              f"median {results[name]['seconds_per_query_median'] * 1000:.1f} ms per query (k={args.k}); "
              f"gripper pattern match {results[name]['gripper_pattern_match_percent']:g} %, "
              f"real change cosine {results[name]['change_cosine']:.3f} ± {results[name]['change_cosine_sem']:.3f} (s.e.m. over queries)")
        print("| held-out task | top source tasks (% of retrieved demos) | distinct tasks |")
        print("|---|---|---|")
        for task in tasks:
            top = ", ".join(f"{t} {p:g}" for t, p in list(rows[task].items())[:3])
            print(f"| {task} | {top} | {len(rows[task])} |")
    if args.json:
        settings = {"k": args.k, "queries_per_task": args.queries_per_task, "steps": args.steps, "text_weight": args.text_weight}
        Path(args.json).write_text(json.dumps({**settings, "results": results}, indent=2))


if __name__ == "__main__":
    main()
