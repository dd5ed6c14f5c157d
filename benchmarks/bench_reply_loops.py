"""Why replies loop: the prompts of a finished run, answered again under two or more decoding
settings of a llama.cpp model, side by side (prints figures; not a test).

For each setting: replies that close their action list, replies cut by the token budget, the
longest run of one repeated action, the distinct actions per reply, and seconds per call. The
prompts are the recorded ones (transcripts/ of an `xicm-eval` run), so they are the real X-ICM
prompts of real episodes, first calls and re-asks alike.

    .venv/bin/python benchmarks/bench_reply_loops.py RUN_DIR --llm qwen2_5_coder_0_5b --calls 20 \
        --settings "paper:repeat_penalty=1.05,repeat_last_n=-1" "no_penalty:repeat_penalty=1.0"
    .venv/bin/python benchmarks/bench_reply_loops.py RUN_DIR --per-task 1 --calls 23 --out replies.json ...
    .venv/bin/python benchmarks/bench_reply_loops.py replies.json --table     # the table again, from the file
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
ACTION = re.compile(r"\[\d+, \d+, \d+, \d+, \d+, \d+, [01]\]")


def recorded_prompts(run_dir: Path, limit: int, per_task: int = 0) -> list[list[dict]]:
    """The first `limit` prompts of the run's transcripts, in file order (task, seed, episode);
    with per_task > 0, only the first call of the first `per_task` episodes of each task (an
    LLM-free run such as nearest_demo records that call for every task)."""
    prompts = []
    for task_dir in sorted((run_dir / "transcripts").iterdir()):
        for path in sorted(task_dir.glob("*.json"))[: per_task or None]:
            calls = json.loads(path.read_text())["calls"]
            prompts += [call["messages"] for call in (calls[:1] if per_task else calls)]
        if len(prompts) >= limit:
            break
    return prompts[:limit]


def parse_setting(text: str) -> tuple[str, dict]:
    name, _, pairs = text.partition(":")
    options = {}
    for pair in filter(None, pairs.split(",")):
        key, _, value = pair.partition("=")
        options[key.strip()] = yaml.safe_load(value)
    return name, options


def reply_figures(reply: str) -> dict:
    actions = ACTION.findall(reply)
    longest = run = 1 if actions else 0
    for before, after in zip(actions, actions[1:]):
        run = run + 1 if after == before else 1
        longest = max(longest, run)
    return {"closed": reply.rstrip().endswith("]]"), "actions": len(actions), "longest_run": longest,
            "distinct": len(set(actions))}


def print_table(figures: dict[str, list[dict]]) -> None:
    first = next(iter(figures))
    print("\nsetting        same reply as " + first + "  closed  cut-at-budget  run>=4  median actions  median longest run  median distinct  median s/call  median tokens")
    for name, rows in figures.items():
        closed = sum(r["closed"] for r in rows)
        same = sum(r["reply"] == f["reply"] for r, f in zip(rows, figures[first]))
        print(f"{name:14s} {same:3d}/{len(rows)}  {closed:3d}/{len(rows)}  {len(rows) - closed:3d}/{len(rows)}  "
              f"{sum(r['longest_run'] >= 4 for r in rows):3d}/{len(rows)}  "
              f"{statistics.median(r['actions'] for r in rows):14.0f}  {statistics.median(r['longest_run'] for r in rows):18.0f}  "
              f"{statistics.median(r['distinct'] for r in rows):15.0f}  {statistics.median(r['s'] for r in rows):13.1f}  "
              f"{statistics.median(r['tokens'] for r in rows):13.0f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("--llm", default="qwen2_5_coder_0_5b", help="an alias in src/xicm/conf/llm/ on the llamacpp engine")
    parser.add_argument("--calls", type=int, default=20)
    parser.add_argument("--per-task", type=int, default=0, help="first calls of this many episodes per task (0: every call)")
    parser.add_argument("--settings", nargs="+", default=["paper:", "no_penalty:repeat_penalty=1.0,repeat_last_n=64"])
    parser.add_argument("--out", type=Path, help="also write every reply and its figures to this JSON file")
    parser.add_argument("--table", action="store_true", help="print the table of an --out file given as run_dir, and stop")
    args = parser.parse_args()
    if args.table:
        print_table(json.loads(args.run_dir.read_text())["replies"])
        return

    from bench_llm_stage import llm_options
    from xicm.plugins.llms.llamacpp import LlamaCppLLM
    from xicm.plugins.llms.llamacpp_options import LlamaCppOptions

    conf = llm_options(args.llm)
    settings = [parse_setting(s) for s in args.settings]
    prompts = recorded_prompts(args.run_dir, args.calls, args.per_task)
    llms = {name: LlamaCppLLM(LlamaCppOptions(**{**conf, **options})) for name, options in settings}
    for llm in llms.values():
        llm.start()
    print(f"{len(prompts)} recorded prompts of {args.run_dir}, model {args.llm}, settings "
          + "; ".join(f"{name} {options}" for name, options in settings))
    figures = {name: [] for name in llms}
    for i, messages in enumerate(prompts):
        for name, llm in llms.items():  # settings alternate call by call: load hits all alike
            t0 = time.perf_counter()
            reply = llm.complete_messages(messages)
            figures[name].append({**reply_figures(reply), "s": time.perf_counter() - t0, "reply": reply,
                                  "tokens": llm.last_call.get("completion_tokens", 0)})
        print(f"{i}: " + "  ".join(f"{n} {f[-1]['actions']}a run{f[-1]['longest_run']} "
                                    f"{'closed' if f[-1]['closed'] else 'CUT'} {f[-1]['s']:.1f}s" for n, f in figures.items()),
              flush=True)
    print_table(figures)
    if args.out:
        args.out.write_text(json.dumps({"run_dir": str(args.run_dir), "llm": args.llm, "settings": dict(settings),
                                        "replies": figures}, indent=1))


if __name__ == "__main__":
    main()
