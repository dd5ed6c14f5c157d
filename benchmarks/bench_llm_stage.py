"""LLM-stage seconds per call and per episode with the embedded Gemma 3 270M: plain `generate`
(``llm.fast=false``) against the fast path (stop at the action list, prefix cache, draft-checking
greedy loop), on the same real X-ICM prompts, side by side (prints figures; not a test).

    .venv/bin/python benchmarks/bench_llm_stage.py                      # 2 episodes x 2 calls, k=18
    .venv/bin/python benchmarks/bench_llm_stage.py --episodes 1 --calls 3 --k 6 --batch

Prompts: the xicm prompt builder on demos of a local pool (data/pools/seen.h5, else smoke.h5).
Per episode a query demo is drawn (seeded), its k demos are drawn from the rest of the pool
(other demos of its task excluded when the pool has other tasks), and the policy's re-asks
are imitated: call c of an episode has the same demos and the query's objects moved by c cm,
as when the policy asks again after executing the previous reply. Decoding options come from
conf/llm/gemma3_270m.yaml (max_new_tokens, chat_template, stop); plain and fast calls alternate,
so load from other processes hits both alike. `--batch` also answers the first call of every
episode with one `complete_batch` call.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def default_pool() -> Path:
    seen = ROOT / "data" / "pools" / "seen.h5"
    return seen if seen.exists() else ROOT / "data" / "pools" / "smoke.h5"


def build_episodes(pool_path, n_episodes: int, calls_per_episode: int, k: int, seed: int = 0):
    """n_episodes lists of calls_per_episode real X-ICM prompts (see the module docstring)."""
    from xicm.core.dataset import load_pool, pool_info
    from xicm.core.types import Query
    from xicm.plugins.prompts.xicm_prompt import XicmPromptBuilder

    workspace = pool_info(pool_path)["workspace"]
    pool = load_pool(pool_path, with_images=False)
    builder = XicmPromptBuilder()
    episodes = []
    for episode in range(n_episodes):
        rng = np.random.default_rng([seed, episode])
        query_demo = pool[int(rng.integers(len(pool)))]
        others = [d for d in pool if d.task != query_demo.task] or [d for d in pool if d is not query_demo]
        demos = [others[int(i)] for i in rng.choice(len(others), size=min(k, len(others)), replace=False)]
        calls = []
        for call in range(calls_per_episode):
            objects = {name: (x + 0.01 * call, y, z) for name, (x, y, z) in query_demo.objects.items()}
            query = Query(query_demo.task, query_demo.instruction, objects)
            calls.append(builder.build(demos, query, workspace))
        episodes.append(calls)
    return episodes


def llm_options(max_new_tokens: int | None) -> dict:
    """The embedded model's decoding options from conf/llm/gemma3_270m.yaml."""
    import yaml

    conf = yaml.safe_load((ROOT / "conf" / "llm" / "gemma3_270m.yaml").read_text())
    keep = ("max_new_tokens", "do_sample", "max_prompt_tokens", "chat_template", "prompt_overflow", "stop")
    options = {key: conf[key] for key in keep if key in conf}
    if max_new_tokens:
        options["max_new_tokens"] = max_new_tokens
    return options


def timed(fn, *args):
    t0 = time.perf_counter()
    out = fn(*args)
    return out, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pool", type=Path, default=default_pool())
    parser.add_argument("--episodes", type=int, default=2)
    parser.add_argument("--calls", type=int, default=2, help="LLM calls per episode")
    parser.add_argument("--k", type=int, default=18, help="demos per prompt")
    parser.add_argument("--max-new-tokens", type=int, default=None, help="default: the config's")
    parser.add_argument("--draft-tokens", type=int, default=16)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--batch", action="store_true", help="also time complete_batch on the first calls")
    args = parser.parse_args()

    import torch
    from xicm.core.parsing import parse_actions
    from xicm.plugins.llms.transformers_local import TransformersLocalLLM

    episodes = build_episodes(args.pool, args.episodes, args.calls, args.k, args.seed)
    options = llm_options(args.max_new_tokens)
    plain = TransformersLocalLLM(fast=False, **options)
    fast = TransformersLocalLLM(draft_tokens=args.draft_tokens, **options)
    plain.load()
    fast.load()
    print(f"pool {args.pool.name}, {args.episodes} episodes x {args.calls} calls, k={args.k}, "
          f"options {options}, draft_tokens={args.draft_tokens}, torch threads {torch.get_num_threads()}")
    print("episode call prompt_tokens reused plain_s fast_s (prefill+decode) plain_tokens fast_tokens same_text same_parse")
    rows = []
    plain_replies = {}
    for e, calls in enumerate(episodes):
        for c, prompt in enumerate(calls):
            ids = plain._fit(plain.encode(prompt.messages))
            plain_reply, plain_s = timed(plain.complete, prompt)
            fast_reply, fast_s = timed(fast.complete, prompt)
            end = fast.reply_text(plain_reply)  # plain's text cut where the fast path stops
            same_text = fast_reply == end
            same_parse = parse_actions(fast_reply, prompt.workspace) == parse_actions(plain_reply, prompt.workspace)
            n_plain = len(plain._tokenizer(plain_reply, add_special_tokens=False)["input_ids"])
            n_fast = len(fast._tokenizer(fast_reply, add_special_tokens=False)["input_ids"])
            rows.append((e, c, plain_s, fast_s, same_text, same_parse))
            plain_replies[e, c] = plain_reply
            split = fast.last_call
            print(f"{e} {c} {len(ids)} {split['reused_tokens']} {plain_s:.1f} {fast_s:.1f} "
                  f"({split['prefill_s']:.1f}+{split.get('decode_s', float('nan')):.1f}) "
                  f"{n_plain} {n_fast} {same_text} {same_parse}")
            if not same_text:
                print(f"  plain: {plain_reply!r}\n  fast:  {fast_reply!r}")
    per_call = {name: statistics.median(r[i] for r in rows) for name, i in (("plain", 2), ("fast", 3))}
    per_episode = {
        name: statistics.median(sum(r[i] for r in rows if r[0] == e) for e in range(args.episodes))
        for name, i in (("plain", 2), ("fast", 3))
    }
    print(f"median s per call:    plain {per_call['plain']:.1f}  fast {per_call['fast']:.1f}  "
          f"ratio {per_call['plain'] / per_call['fast']:.2f}x")
    print(f"median s per episode: plain {per_episode['plain']:.1f}  fast {per_episode['fast']:.1f}  "
          f"ratio {per_episode['plain'] / per_episode['fast']:.2f}x")
    print(f"identical replies (text up to the fast stop): {all(r[4] for r in rows)}; "
          f"identical parsed actions: {all(r[5] for r in rows)}")
    if args.batch:
        firsts = [calls[0] for calls in episodes]
        batch, batch_s = timed(fast.complete_batch, firsts)
        single = [fast.reply_text(plain_replies[e, 0]) for e in range(args.episodes)]
        print(f"complete_batch of {len(firsts)} first calls: {batch_s:.1f} s "
              f"(plain one by one above: {sum(r[2] for r in rows if r[1] == 0):.1f} s); "
              f"identical to one by one: {batch == single}")


if __name__ == "__main__":
    main()
