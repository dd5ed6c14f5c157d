"""Where an anchored LLM row wins or loses against the replay, by what its first reply copies (prints figures)

Pairs an LLM run made with `prompt.actions=anchored` with a `nearest_demo` run on the same episodes
(task, seed, episode) and sorts each common episode by its first call:
- what the LLM's first reply is: the first demo's list whole, another demo's list whole, or no
  whole list (`benchmarks/reply_copies.py` sorts every reply the same way);
- whether the replay's first reply puts its actions on the same query objects, in order, as the
  first demo's list names (an anchored action's first number is its object): a copied list lands
  where the replay's does only then, since the replay maps demo objects to the query's by name or
  place and a copied list keeps the demo's object numbers.
Per group: episodes, successes of each run and the discordant pairs (LLM only / replay only).

    python benchmarks/copies_against_replay.py LLM_RUN REPLAY_RUN
"""

from __future__ import annotations

import argparse
import collections
import json
from pathlib import Path

from reply_copies import ANCHORED, DEMO_ACTIONS, sort_reply


def objects(actions: list[str]) -> list[str]:
    return [action[1:].split(",")[0] for action in actions]


def first_reply_kind(prompt: str, reply: str) -> str:
    labels = sort_reply(prompt, reply, near=0)
    equal = next((label for label in labels if label.startswith("equals demo")), None)
    if equal is None:
        return "no whole demo list"
    return "the first demo's list" if equal.startswith("equals demo 1 ") else "another demo's list"


def episodes(run: Path) -> dict[tuple, dict]:
    rows = (json.loads(line) for line in (run / "episodes.jsonl").read_text().splitlines() if line.strip())
    return {(row["task"], int(row["seed"]), int(row["episode"])): row for row in rows}


def groups(llm_run: Path, replay_run: Path) -> dict[tuple[str, bool], list[int]]:
    """(kind, replay keeps demo 1's objects) -> [episodes, LLM successes, replay successes, LLM only, replay only]."""
    replay = episodes(replay_run)
    out: dict[tuple[str, bool], list[int]] = collections.defaultdict(lambda: [0, 0, 0, 0, 0])
    for key, row in episodes(llm_run).items():
        path = llm_run / "transcripts" / row["task"] / f"s{key[1]}-e{key[2]:04d}.json"
        if key not in replay or not path.exists() or not replay[key]["responses"]:
            continue
        call = json.loads(path.read_text())["calls"][0]
        prompt = call["messages"][-1]["content"]
        demos = [ANCHORED.findall(text) for text in DEMO_ACTIONS.findall(prompt)]
        if not demos or not demos[0]:
            raise SystemExit(f"{path} holds no anchored demo actions: the LLM run must use prompt.actions=anchored")
        replay_first = ANCHORED.findall(replay[key]["responses"][0])
        keeps = objects(replay_first[:len(demos[0])]) == objects(demos[0])
        a, b = bool(row["success"]), bool(replay[key]["success"])
        cell = out[(first_reply_kind(prompt, call["reply"]), keeps)]
        for i, value in enumerate((1, a, b, a and not b, b and not a)):
            cell[i] += value
    return dict(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("llm_run", type=Path, help="an xicm-eval run with prompt.actions=anchored and transcripts/")
    parser.add_argument("replay_run", type=Path, help="the nearest_demo run on the same episodes")
    args = parser.parse_args()
    for run in (args.llm_run, args.replay_run):
        if not (run / "episodes.jsonl").exists():
            parser.error(f"{run} holds no episodes.jsonl: give xicm-eval run folders")
    if not any(args.llm_run.glob("transcripts/*/*.json")):
        parser.error(f"{args.llm_run} holds no transcripts/<task>/*.json: run xicm-eval with transcripts=true")
    table = groups(args.llm_run, args.replay_run)
    print("| the LLM's first reply | replay keeps demo 1's objects | episodes | LLM | replay | LLM only / replay only |")
    print("|---|---|---:|---:|---:|---:|")
    for (kind, keeps), (n, a, b, only_a, only_b) in sorted(table.items()):
        print(f"| {kind} | {'yes' if keeps else 'no'} | {n} | {a} | {b} | {only_a} / {only_b} |")


if __name__ == "__main__":
    main()
