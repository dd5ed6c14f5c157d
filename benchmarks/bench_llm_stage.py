"""LLM-stage seconds per call and per episode with the embedded Gemma 3 270M, side by side on the
same real X-ICM prompts (prints figures; not a test). Modes:

    plain            plain `generate` (llm.fast=false, llm.grammar=none)
    fast             today's fast path (stop at the action list, prefix cache, draft-checking
                     greedy loop), llm.grammar=none
    grammar          the fast path under llm.grammar=actions, output layer over the whole vocabulary
    grammar_reduced  the same with the output layer evaluated only on the allowed tokens
    grammar_cut      grammar_reduced that ends the reply before a repeated action
                     (llm.on_repeated_action: cut)
    grammar_fill     grammar_reduced that stops decoding at a repeated action and writes the
                     repeat on to the token budget (llm.on_repeated_action: fill)
    grammar_draft64  grammar_reduced checking up to 64 guessed tokens per pass (llm.draft_tokens)
    grammar_bf16     grammar_reduced with the dequantised weights, states and activations in
                     bfloat16 (llm.dtype=bfloat16; the default is float32, which holds the GGUF's
                     dequantised values exactly): half the bytes per forward pass, other numerics
    llamacpp_gemma   the same Gemma 3 270M GGUF on llama.cpp (llm=gemma3_270m_llamacpp: greedy,
                     action grammar, raw rendering, prefix reuse in llama-server's KV cache)
    llamacpp_qwen0_5b / llamacpp_qwen1_5b
                     Qwen2.5-Coder-0.5B / 1.5B-Instruct on llama.cpp (llm=qwen2_5_coder_0_5b /
                     _1_5b: their chat template, action grammar, the paper's decoding values)

llama.cpp modes also report prefill and decode tokens/s (llama-server's own timings) and the
prompt tokens it reused; the share of replies identical between grammar_reduced and
llamacpp_gemma compares the two engines on the same model (both greedy, both constrained).

For each it reports LLM seconds per call and per episode, the parse_error rate (the project's
parser, `xicm.core.text.parsing.parse_actions`) and whether the parsed actions agree with the first
mode's; replies of the two grammar modes must be identical. Against grammar_reduced (whole
replies) it counts, for grammar_fill, the replies whose parsed actions are equal, and for
grammar_cut those whose actions are equal once consecutive repeats are collapsed (that move the
robot as the whole reply would, with fewer actions).

    .venv/bin/python benchmarks/bench_llm_stage.py                      # 2 episodes x 2 calls, k=18
    .venv/bin/python benchmarks/bench_llm_stage.py --modes grammar_reduced,fast --episodes 5 --calls 10
    .venv/bin/python benchmarks/bench_llm_stage.py --episodes 1 --calls 3 --k 6 --batch

Prompts: the xicm prompt builder on demos of a local pool (data/pools/seen.h5, else smoke.h5).
Per episode a query demo is drawn (seeded), its k demos are drawn from the rest of the pool
(other demos of its task excluded when the pool has other tasks), and the policy's re-asks
are imitated: call c of an episode has the same demos and the query's objects moved by c cm,
as when the policy asks again after executing the previous reply. Decoding options come from
src/xicm/conf/llm/gemma3_270m.yaml (max_new_tokens, chat_template, stop); the modes alternate call by call,
so load from other processes hits all alike. `--batch` also answers the first call of every
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


def build_episodes(pool_path, n_episodes: int, calls_per_episode: int, k: int, seed: int = 0, shared_demos: bool = False):
    """n_episodes lists of calls_per_episode real X-ICM prompts (see the module docstring).

    shared_demos: every episode is episode 0's task with the same demos and its objects moved by
    3 cm more per episode (consecutive episodes of one task, whose instruction retrieves the same
    demos), so the prefix cache carries over from one episode to the next as in a run."""
    from xicm.core.results.dataset import load_pool, pool_info
    from xicm.core.contracts.types import Query
    from xicm.plugins.prompts.xicm_prompt import XicmPromptBuilder

    workspace = pool_info(pool_path)["workspace"]
    pool = load_pool(pool_path, with_images=False)
    builder = XicmPromptBuilder()
    episodes = []
    for episode in range(n_episodes):
        rng = np.random.default_rng([seed, 0 if shared_demos else episode])
        query_demo = pool[int(rng.integers(len(pool)))]
        others = [d for d in pool if d.task != query_demo.task] or [d for d in pool if d is not query_demo]
        demos = [others[int(i)] for i in rng.choice(len(others), size=min(k, len(others)), replace=False)]
        calls = []
        for call in range(calls_per_episode):
            shift = 0.01 * call + (0.03 * episode if shared_demos else 0.0)
            objects = {name: (x + shift, y, z) for name, (x, y, z) in query_demo.objects.items()}
            query = Query(query_demo.task, query_demo.instruction, objects)
            calls.append(builder.build(demos, query, workspace))
        episodes.append(calls)
    return episodes


def gemma_options(max_new_tokens: int | None) -> dict:
    """The embedded model's decoding options from src/xicm/conf/llm/gemma3_270m.yaml."""
    import yaml

    conf = yaml.safe_load((ROOT / "src/xicm/conf" / "llm" / "gemma3_270m.yaml").read_text())
    keep = ("max_new_tokens", "do_sample", "max_prompt_tokens", "chat_template", "prompt_overflow", "stop")
    options = {key: conf[key] for key in keep if key in conf}
    if max_new_tokens:
        options["max_new_tokens"] = max_new_tokens
    return options


MODES = {
    "plain": {"fast": False, "grammar": "none"},
    "fast": {"grammar": "none"},
    "grammar": {"grammar": "actions", "reduced_output_layer": False, "on_repeated_action": "decode"},
    "grammar_reduced": {"grammar": "actions", "reduced_output_layer": True, "on_repeated_action": "decode"},
    "grammar_cut": {"grammar": "actions", "reduced_output_layer": True, "on_repeated_action": "cut"},
    "grammar_fill": {"grammar": "actions", "reduced_output_layer": True, "on_repeated_action": "fill"},
    "grammar_draft64": {"grammar": "actions", "reduced_output_layer": True, "on_repeated_action": "decode", "draft_tokens": 64},
    "grammar_bf16": {"grammar": "actions", "reduced_output_layer": True, "on_repeated_action": "decode", "dtype": "bfloat16"},
}


#: llama.cpp modes: the alias in src/xicm/conf/llm/ whose options they run with
LLAMACPP_MODES = {
    "llamacpp_gemma": "gemma3_270m_llamacpp",
    "llamacpp_qwen0_5b": "qwen2_5_coder_0_5b",
    "llamacpp_qwen1_5b": "qwen2_5_coder_1_5b",
}


def llm_options(alias: str) -> dict:
    """The options of `llm=<alias>` as a run composes them (the alias's defaults included)."""
    from hydra import compose, initialize_config_module
    from omegaconf import OmegaConf

    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        cfg = compose(config_name="config", overrides=[f"llm={alias}"])
    options = OmegaConf.to_container(cfg.llm, resolve=True)
    options.pop("name")
    return options


def llamacpp_llm(mode: str, max_new_tokens: int | None):
    from xicm.plugins.llms.llamacpp import LlamaCppLLM
    from xicm.plugins.llms.llamacpp_options import LlamaCppOptions

    conf = llm_options(LLAMACPP_MODES[mode])
    if max_new_tokens:
        conf["max_tokens"] = max_new_tokens
    llm = LlamaCppLLM(LlamaCppOptions(**conf))
    llm.start()  # model fetch and server start are not part of the timed calls
    return llm


def collapse_repeats(actions):
    """Actions with each run of equal consecutive actions kept once (a repeat moves nothing)."""
    if not isinstance(actions, list):
        return actions
    return [a for i, a in enumerate(actions) if i == 0 or a != actions[i - 1]]


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
    parser.add_argument("--modes", default=",".join(MODES), help=f"comma-separated, from: {', '.join([*MODES, *LLAMACPP_MODES])}")
    parser.add_argument("--max-new-tokens", type=int, default=None, help="default: the config's")
    parser.add_argument("--draft-tokens", type=int, default=16)
    parser.add_argument("--torch-threads", type=int, default=None, help="default: torch's")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--shared-demos", action="store_true", help="episodes of one task share their demos (see build_episodes)")
    parser.add_argument("--batch", action="store_true", help="also time complete_batch on the first calls")
    args = parser.parse_args()
    modes = [m.strip() for m in args.modes.split(",") if m.strip()]
    unknown = [m for m in modes if m not in MODES and m not in LLAMACPP_MODES]
    if unknown:
        parser.error(f"--modes: unknown {', '.join(unknown)}; available: {', '.join([*MODES, *LLAMACPP_MODES])}")

    import torch
    from xicm.core.text.parsing import ParseError, parse_actions
    from xicm.plugins.llms import stopping
    from xicm.plugins.llms.transformers_local import TransformersLocalLLM
    from xicm.plugins.llms.transformers_local_options import TransformersLocalOptions

    episodes = build_episodes(args.pool, args.episodes, args.calls, args.k, args.seed, args.shared_demos)
    options = gemma_options(args.max_new_tokens)
    options["torch_threads"] = args.torch_threads
    llms = {m: TransformersLocalLLM(TransformersLocalOptions(**{**options, "draft_tokens": args.draft_tokens, **MODES[m]})) for m in modes if m in MODES}
    llms.update({m: llamacpp_llm(m, args.max_new_tokens) for m in modes if m in LLAMACPP_MODES})
    llms = {m: llms[m] for m in modes}
    matchers = None
    for llm in llms.values():
        if not isinstance(llm, TransformersLocalLLM):
            continue
        llm.load()
        if llm.grammar != "none":  # one tokenizer conversion for all grammar modes
            if matchers is None:
                t0 = time.perf_counter()
                matchers = llm.generator.matchers()
                print(f"llguidance tokenizer conversion: {time.perf_counter() - t0:.1f} s (once per process)")
            llm.generator._matchers = matchers
    print(f"pool {args.pool}, {args.episodes} episodes x {args.calls} calls, k={args.k}, options {options}, "
          f"draft_tokens={args.draft_tokens}, torch threads {torch.get_num_threads()}")
    print("episode call prompt_tokens " + " ".join(f"{m}_s" for m in modes) + "  (reused prompt tokens; new tokens)")
    seconds = {m: [] for m in modes}  # (episode, s) per call
    parsed = {m: [] for m in modes}
    replies = {m: {} for m in modes}
    server_timings = {m: [] for m in modes if m in LLAMACPP_MODES}
    for e, calls in enumerate(episodes):
        for c, prompt in enumerate(calls):
            row, n_prompt = [], {}
            for m in modes:
                reply, s = timed(llms[m].complete, prompt)
                seconds[m].append((e, s))
                parsed[m].append(parse_actions(reply, prompt.workspace))
                replies[m][e, c] = reply
                split = llms[m].last_call
                if m in LLAMACPP_MODES:
                    server_timings[m].append(split)
                    n_prompt[m] = split.get("prompt_tokens")
                    row.append(f"{s:.1f}({split.get('cache_n', 0)};{split.get('predicted_n', '-')})")
                else:
                    n_prompt.setdefault("transformers", len(llms[m].prompts.fit(llms[m].prompts.encode(prompt.messages))))
                    row.append(f"{s:.1f}" + (f"({split.get('reused_tokens', 0)};{split.get('new_tokens', '-')})" if llms[m].options.fast else ""))
            print(f"{e} {c} {n_prompt} " + " ".join(row), flush=True)
            for m in modes:
                print(f"    {m:16s} {replies[m][e, c]!r}")
    n_calls = len(parsed[modes[0]])
    print(f"\n{n_calls} calls per mode; median s per call / per episode; speed-up over grammar_reduced (else fast) per episode; parse_error rate; "
          f"parsed actions equal to {modes[0]}'s")
    totals = {m: [sum(s for ep, s in seconds[m] if ep == e) for e in range(args.episodes)] for m in modes}
    per_episode = {m: statistics.median(totals[m]) for m in modes}
    for m in modes:
        errors = sum(isinstance(p, ParseError) for p in parsed[m])
        agree = sum(a == b for a, b in zip(parsed[m], parsed[modes[0]]))
        base = "grammar_reduced" if "grammar_reduced" in per_episode else "fast"
        ratio = f"{per_episode[base] / per_episode[m]:.1f}x" if base in per_episode else "-"
        print(f"{m:16s} {statistics.median(s for _, s in seconds[m]):7.1f} s/call {per_episode[m]:7.1f} s/episode  "
              f"{ratio:>6s}  parse_error {errors}/{n_calls} ({errors / n_calls:.0%})  same actions {agree}/{n_calls}")
    if args.shared_demos and args.episodes > 1:
        print("episodes after the first (their demos' prefix cached by the first): median s/episode "
              + ", ".join(f"{m} {statistics.median(totals[m][1:]):.1f}" for m in modes))
    for m, timings in server_timings.items():
        prefill = sum(t.get("prompt_n", 0) for t in timings) / max(1e-9, sum(t.get("prompt_ms", 0) for t in timings) / 1000)
        decode = sum(t.get("predicted_n", 0) for t in timings) / max(1e-9, sum(t.get("predicted_ms", 0) for t in timings) / 1000)
        print(f"{m:16s} llama-server: prefill {prefill:.0f} tokens/s, decode {decode:.1f} tokens/s; prompt tokens "
              f"{statistics.median(t.get('prompt_tokens', 0) for t in timings):.0f} (median), of which reused "
              f"{statistics.median(t.get('cache_n', 0) for t in timings):.0f} (median)")
    if "grammar_reduced" in modes and "llamacpp_gemma" in modes:
        same = sum(replies["grammar_reduced"][key] == replies["llamacpp_gemma"][key] for key in replies["llamacpp_gemma"])
        print(f"llamacpp_gemma replies identical to grammar_reduced (transformers, same GGUF): {same}/{n_calls}")
    if "grammar_reduced" in modes and "grammar_bf16" in modes:
        same = sum(replies["grammar_bf16"][key] == replies["grammar_reduced"][key] for key in replies["grammar_reduced"])
        agree = sum(a == b for a, b in zip(parsed["grammar_bf16"], parsed["grammar_reduced"]))
        print(f"grammar_bf16 replies identical to grammar_reduced (float32): {same}/{n_calls}; same parsed actions {agree}/{n_calls}")
    if "grammar" in modes and "grammar_reduced" in modes:
        same = replies["grammar"] == replies["grammar_reduced"]
        print(f"grammar_reduced replies identical to grammar (full vocabulary): {same}")
    if "grammar_reduced" in modes and "grammar_cut" in modes:
        pairs = list(zip(parsed["grammar_cut"], parsed["grammar_reduced"]))
        same_motion = sum(collapse_repeats(a) == collapse_repeats(b) for a, b in pairs)
        print(f"grammar_cut replies that move the robot as grammar_reduced's (repeats collapsed): "
              f"{same_motion}/{len(pairs)}")
    if "grammar_reduced" in modes and "grammar_fill" in modes:
        pairs = list(zip(parsed["grammar_fill"], parsed["grammar_reduced"]))
        print(f"grammar_fill replies with grammar_reduced's actions exactly: {sum(a == b for a, b in pairs)}/{len(pairs)}; "
              f"that repeated an action: {sum(stopping.repeated_action_end(r) is not None for r in replies['grammar_reduced'].values())}")
    if args.batch:
        first = llms[modes[-1]]
        firsts = [calls[0] for calls in episodes]
        batch, batch_s = timed(first.complete_batch, firsts)
        single = [replies[modes[-1]][e, 0] for e in range(args.episodes)]
        print(f"complete_batch ({modes[-1]}) of {len(firsts)} first calls: {batch_s:.1f} s; identical to one by one: {batch == single}")


if __name__ == "__main__":
    main()
