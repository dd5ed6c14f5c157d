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
from xicm.core.results.run_dir import RunDir

COLUMNS = ("episodes", "llm", "replay", "llm only", "replay only")


def objects(actions: list[str]) -> list[str]:
    """The object numbers of anchored actions (`[object, dx, dy, dz, ...]`)."""
    return [action[1:].split(",")[0] for action in actions]


def first_reply_kind(prompt: str, reply: str) -> str:
    labels = sort_reply(prompt, reply, near=0)
    equal = next((label for label in labels if label.startswith("equals demo")), None)
    if equal is None:
        return "no whole demo list"
    return "the first demo's list" if equal.startswith("equals demo 1 ") else "another demo's list"


def by_episode(run: RunDir) -> dict[tuple, dict]:
    """The run's configured episodes (as `xicm-report --paired` counts them) by (task, seed, episode)."""
    return {(row["task"], int(row["seed"]), int(row["episode"])): row for row in run.rows()}


def groups(llm_run: RunDir, replay_run: RunDir) -> dict[tuple[str, bool], collections.Counter]:
    """(kind, replay keeps demo 1's objects) -> counts of COLUMNS."""
    replay = by_episode(replay_run)
    out: dict[tuple[str, bool], collections.Counter] = collections.defaultdict(collections.Counter)
    for key, row in by_episode(llm_run).items():
        path = llm_run.transcript(*key)
        if key not in replay or not path.exists() or not replay[key]["responses"]:
            continue
        call = json.loads(path.read_text())["calls"][0]
        prompt = call["messages"][-1]["content"]
        demos = [ANCHORED.findall(text) for text in DEMO_ACTIONS.findall(prompt)]
        if not demos or not demos[0]:
            raise SystemExit(f"{path} holds no anchored demo actions: the LLM run must use prompt.actions=anchored")
        keeps = objects(ANCHORED.findall(replay[key]["responses"][0])[:len(demos[0])]) == objects(demos[0])
        a, b = bool(row["success"]), bool(replay[key]["success"])
        out[(first_reply_kind(prompt, call["reply"]), keeps)].update(
            {"episodes": 1, "llm": int(a), "replay": int(b), "llm only": int(a and not b), "replay only": int(b and not a)})
    return dict(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("llm_run", type=Path, help="an xicm-eval run with prompt.actions=anchored and transcripts/")
    parser.add_argument("replay_run", type=Path, help="the nearest_demo run on the same episodes")
    args = parser.parse_args()
    llm_run, replay_run = RunDir(args.llm_run), RunDir(args.replay_run)
    for run in (llm_run, replay_run):
        if not run.is_run():
            parser.error(f"{run.path} holds no episodes.jsonl and run.json: give xicm-eval run folders")
    if not any(args.llm_run.glob("transcripts/*/*.json")):
        parser.error(f"{args.llm_run} holds no transcripts/<task>/*.json: run xicm-eval with transcripts=true")
    table = groups(llm_run, replay_run)
    print("| the LLM's first reply | replay keeps demo 1's objects | episodes | LLM | replay | LLM only / replay only |")
    print("|---|---|---:|---:|---:|---:|")
    for (kind, keeps), cell in sorted(table.items()):
        n, a, b, only_a, only_b = (cell[column] for column in COLUMNS)
        print(f"| {kind} | {'yes' if keeps else 'no'} | {n} | {a} | {b} | {only_a} / {only_b} |")


if __name__ == "__main__":
    main()
