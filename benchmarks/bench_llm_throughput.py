"""LLM-stage throughput of the llama.cpp engine on recorded X-ICM prompts: episodes per hour with
one request at a time against several server slots fed by concurrent episodes, side by side in
one run (prints figures; not a test).

The prompts are a finished run's transcripts (an `xicm-eval ... transcripts=true` run; an
LLM-free `llm=nearest_demo` run records every call of its episodes in seconds), grouped by
episode: an episode's calls go one after another, as the policy asks again after executing a
reply, and `clients` episodes run at once, as `envs=N` slots do. Each mode is one server setting
and a number of concurrent episodes:

    serial       the alias as it is (one slot), one episode at a time
    serial_nospec   the same without speculative decoding (llm.speculative=none)
    serial_d64   serial with llama.cpp's own ngram-mod sizes (draft_max 64, draft_min 48,
                 draft_lookup 24): the engine every run had before draft_max reached the server
    slots2       llm.parallel=2, two episodes at a time (envs=2)
    slots4       llm.parallel=4, four episodes at a time (envs=4)
    slots2_nospec   slots2 without speculative decoding
    slots2_max8  slots2 with replies bounded to 8 actions by the grammar (llm.max_actions=8)
    slots2_d64   slots2 with llama.cpp's own ngram-mod sizes (as serial_d64)
    slots2_short slots2 with short drafts found from short lookups (draft_max 16, draft_min 2,
                 draft_lookup 12)
    slots2_simple   slots2 with ngram-simple drafts (draft_max 16, draft_lookup 12)

Modes run one after another on the same episodes, each on a fresh server (a cold cache), and
the order alternates over `--rounds`, so slow phases of the machine hit all alike. Reported per
mode: wall seconds, episodes/hour, LLM seconds per episode (wall x clients / episodes), prefill
and decode tokens/s, prompt tokens reused and draft tokens accepted of those tried (llama-server's
timings), and the replies identical to the first mode's, the baseline of the ratios (greedy
decoding; a batch or a draft's check sums in another order, so a reply may differ).

    .venv/bin/python benchmarks/bench_llm_throughput.py RUN_DIR --llm qwen2_5_coder_0_5b --episodes 8
    .venv/bin/python benchmarks/bench_llm_throughput.py RUN_DIR --modes serial,slots2 --set grammar=actions
"""

from __future__ import annotations

import argparse
import json
import statistics
import threading
import time
from pathlib import Path

from bench_llm_stage import llm_options  # the options of `llm=<alias>` as a run composes them


#: mode -> (option overrides, concurrent episodes)
MODES = {
    "serial": ({}, 1),
    "serial_nospec": ({"speculative": "none"}, 1),
    "serial_d64": ({"draft_max": 64, "draft_min": 48, "draft_lookup": 24}, 1),
    "slots2": ({"parallel": 2}, 2),
    "slots4": ({"parallel": 4}, 4),
    "slots2_nospec": ({"parallel": 2, "speculative": "none"}, 2),
    "slots2_max8": ({"parallel": 2, "max_actions": 8}, 2),
    "slots2_d64": ({"parallel": 2, "draft_max": 64, "draft_min": 48, "draft_lookup": 24}, 2),
    "slots2_short": ({"parallel": 2, "draft_max": 16, "draft_min": 2, "draft_lookup": 12}, 2),
    "slots2_simple": ({"parallel": 2, "speculative": "ngram-simple", "draft_max": 16, "draft_lookup": 12}, 2),
}


def recorded_episodes(run_dir: Path, limit: int) -> list[list[list[dict]]]:
    """The first `limit` episodes of the run's transcripts (task folders in name order, episodes
    in file order), each the list of its calls' messages."""
    root = run_dir / "transcripts"
    if not root.is_dir():
        raise SystemExit(f"{run_dir} has no transcripts/: run xicm-eval with transcripts=true first")
    by_task: dict[str, list] = {}
    for task in sorted(root.iterdir()):
        for path in sorted(task.glob("*.json")):
            calls = [call["messages"] for call in json.loads(path.read_text())["calls"]]
            if calls:
                by_task.setdefault(task.name, []).append(calls)
    if not by_task:
        raise SystemExit(f"{root} holds no recorded calls")
    # round-robin over the tasks, so a short list still mixes demo sets as a run does
    mixed = []
    while len(mixed) < limit and any(by_task.values()):
        for task in sorted(by_task):
            if by_task[task] and len(mixed) < limit:
                mixed.append(by_task[task].pop(0))
    return mixed


def parse_value(text: str):
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def run_mode(options: dict, clients: int, episodes: list[list[list[dict]]], anchored: bool = False) -> dict:
    """Every episode through one fresh engine, `clients` episodes at a time; replies keyed by
    (episode, call), llama-server's timings per call, and the wall time."""
    from xicm.plugins.llms.llamacpp import LlamaCppLLM
    from xicm.plugins.llms.llamacpp_options import LlamaCppOptions

    engines = [LlamaCppLLM(LlamaCppOptions(**options)) for _ in range(clients)]  # share one server
    engines[0].start()  # model fetch and server start are not part of the timed wall
    for engine in engines[1:]:
        engine.start()
    replies: dict[tuple[int, int], str] = {}
    timings: list[dict] = []
    queue = list(range(len(episodes)))
    lock = threading.Lock()
    errors: list[BaseException] = []

    def client(engine) -> None:
        while True:
            with lock:
                if not queue or errors:
                    return
                e = queue.pop(0)
            for c, messages in enumerate(episodes[e]):
                try:
                    reply = engine.complete_messages(messages, anchored)
                except BaseException as exc:  # noqa: BLE001 - reported after the threads end
                    with lock:
                        errors.append(exc)
                    return
                with lock:
                    replies[e, c] = reply
                    timings.append(dict(engine.last_call))

    t0 = time.perf_counter()
    threads = [threading.Thread(target=client, args=(engine,)) for engine in engines]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    wall = time.perf_counter() - t0
    engines[0].stop()
    if errors:
        raise SystemExit(f"a request failed: {errors[0]}")
    return {"wall": wall, "replies": replies, "timings": timings}


def summarise(mode: str, clients: int, runs: list[dict], n_episodes: int, baseline: dict | None) -> str:
    walls = [r["wall"] for r in runs]
    wall = statistics.median(walls)
    timings = [t for r in runs for t in r["timings"]]
    prefill_n = sum(t.get("prompt_n", 0) for t in timings)
    prefill_s = sum(t.get("prompt_ms", 0) for t in timings) / 1000
    decode_n = sum(t.get("predicted_n", 0) for t in timings)
    decode_s = sum(t.get("predicted_ms", 0) for t in timings) / 1000
    drafted = sum(t.get("draft_n", 0) for t in timings)
    accepted = sum(t.get("draft_n_accepted", 0) for t in timings)
    reused = statistics.median(t.get("cache_n", 0) for t in timings) if timings else 0
    prompt = statistics.median(t.get("prompt_tokens", 0) for t in timings) if timings else 0
    same = "-"
    if baseline is not None:
        keys = baseline["replies"].keys()
        equal = sum(all(r["replies"].get(k) == baseline["replies"][k] for r in runs) for k in keys)
        same = f"{equal}/{len(keys)}"
    return (f"{mode:14s} {clients:>2d}  wall {wall:7.1f} s (runs {', '.join(f'{w:.1f}' for w in walls)})  "
            f"{3600 * n_episodes / wall:7.1f} episodes/h  {wall * clients / n_episodes:6.1f} LLM s/episode  "
            f"prefill {prefill_n / max(prefill_s, 1e-9):6.1f} tok/s  decode {decode_n / max(decode_s, 1e-9):5.1f} tok/s "
            f"(per stream)  prompt {prompt:.0f} tok, reused {reused:.0f}  drafts {accepted}/{drafted} accepted "
            f"({accepted / max(decode_n, 1):.0%} of decoded)  same {same}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_dir", type=Path, help="an xicm-eval run folder with transcripts/")
    parser.add_argument("--llm", default="qwen2_5_coder_0_5b", help="an llm alias of src/xicm/conf/llm/ (a llamacpp one)")
    parser.add_argument("--episodes", type=int, default=8)
    parser.add_argument("--modes", default="serial,slots2")
    parser.add_argument("--rounds", type=int, default=1, help="passes over the modes, the order reversed each pass")
    parser.add_argument("--anchored", action="store_true", help="the run's prompts write anchored actions (their grammar)")
    parser.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE", help="llm options for every mode")
    args = parser.parse_args()
    modes = [m.strip() for m in args.modes.split(",") if m.strip()]
    unknown = [m for m in modes if m not in MODES]
    if unknown:
        parser.error(f"--modes: unknown {', '.join(unknown)}; available: {', '.join(MODES)}")
    common = dict(item.split("=", 1) for item in args.set)
    common = {key: parse_value(value) for key, value in common.items()}
    episodes = recorded_episodes(args.run_dir, args.episodes)
    n_calls = sum(len(e) for e in episodes)
    print(f"{len(episodes)} recorded episodes ({n_calls} calls) of {args.run_dir}; llm={args.llm} {common}")
    results: dict[str, list[dict]] = {m: [] for m in modes}
    for r in range(args.rounds):
        for mode in (modes if r % 2 == 0 else modes[::-1]):
            overrides, clients = MODES[mode]
            out = run_mode({**llm_options(args.llm), **common, **overrides}, clients, episodes, args.anchored)
            results[mode].append(out)
            print(f"  round {r} {mode}: {out['wall']:.1f} s", flush=True)
    first = modes[0]  # the baseline: ratios and identical replies are against the first mode
    baseline = results[first][0]
    print(f"\nmode       clients  (median over {args.rounds} round(s); tok/s from llama-server's timings; "
          f"'same' against {first})")
    for mode in modes:
        print(summarise(mode, MODES[mode][1], results[mode], len(episodes), baseline if mode != first else None))
    base_wall = statistics.median(r["wall"] for r in results[first])
    print(f"episodes/hour against {first}: " + ", ".join(
        f"{m} {base_wall / statistics.median(r['wall'] for r in results[m]):.2f}x" for m in modes if m != first))


if __name__ == "__main__":
    main()
