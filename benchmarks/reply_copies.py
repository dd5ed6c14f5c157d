"""Do the LLM's replies copy the prompt's demos, or move them to the query's objects? (prints figures)

Reads the transcripts of one or more finished `xicm-eval` runs (transcripts/<task>/*.json: each
call's messages and reply) and sorts every reply that holds at least one action:
- `equals demo i`: the reply's action list is exactly the i-th demo's list in the prompt;
- `all copied`: every action of the reply appears in some demo's list (but no whole list equals it);
- `some copied` / `none copied`: part of the actions, or none, appear in the demos' lists;
- `at a query object`: some action's x and y lie within `--near` voxels of an object of the query
  (the last entry of the prompt, whose objects are given and whose actions are not).

    python benchmarks/reply_copies.py RUN_DIR [RUN_DIR ...] [--near 2]

Written for X-ICM's prompt layout (`prompt=xicm_paper`: entries `[instruction, {objects}]>[[actions]]`),
absolute or anchored actions (`prompt.actions=anchored`: an anchored action is at a query object
when its own x and y offsets are within `--near` voxels).
"""

from __future__ import annotations

import argparse
import ast
import collections
import json
import re
from pathlib import Path

from bench_reply_loops import ACTION  # one action of the reply format, as the loop study reads it

ANCHORED = re.compile(r"\[\d, -?\d+, -?\d+, -?\d+, \d+, \d+, \d+, [01]\]")  # prompt.actions=anchored
DEMO_ACTIONS = re.compile(r"\]>(\[\[.*?\]\])")  # each demo's list follows its observation's "]>"
OBJECTS = re.compile(r"\{[^{}]*\}")


def sort_reply(prompt: str, reply: str, near: int) -> list[str]:
    """The labels of one call (empty when the reply or the prompt holds no action)."""
    anchored = bool(ANCHORED.search(prompt))
    pattern = ANCHORED if anchored else ACTION
    demos = [pattern.findall(text) for text in DEMO_ACTIONS.findall(prompt)]
    actions = pattern.findall(reply)
    if not actions or not demos:
        return []
    labels = []
    equal = [i for i, demo in enumerate(demos) if demo == actions]
    demo_actions = {a for demo in demos for a in demo}
    copied = sum(a in demo_actions for a in actions)
    if equal:
        labels.append(f"equals demo {equal[0] + 1} of {len(demos)}")
    elif copied == len(actions):
        labels.append("all copied")
    else:
        labels.append("some copied" if copied else "none copied")
    if anchored:  # the offsets from an object of the query
        query_objects, xy = [[0, 0]], [tuple(ast.literal_eval(a)[1:3]) for a in actions]
    else:
        observations = OBJECTS.findall(prompt)
        query_objects = _objects(observations[-1]) if observations else []
        xy = [tuple(ast.literal_eval(a)[:2]) for a in actions]
    if any(abs(x - ox) <= near and abs(y - oy) <= near for x, y in xy for ox, oy, *_ in query_objects):
        labels.append("at a query object")
    return labels


def _objects(text: str) -> list[list[int]]:
    """The voxel lists of a `{'name': [x, y, z], ...}` observation; [] when it does not parse."""
    try:
        value = ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return []
    return [v for v in value.values() if isinstance(v, list) and len(v) >= 2] if isinstance(value, dict) else []


def count_run(run_dir: Path, near: int) -> collections.Counter:
    counts = collections.Counter()
    for path in sorted(run_dir.glob("transcripts/*/*.json")):
        for call in json.loads(path.read_text())["calls"]:
            labels = sort_reply(call["messages"][-1]["content"], call["reply"], near)
            counts["calls"] += bool(labels)
            counts.update(labels)
    return counts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="xicm-eval run folders with transcripts/")
    parser.add_argument("--near", type=int, default=2, help="voxels (x and y) that count as at an object")
    args = parser.parse_args()
    for run in args.runs:
        if not any(run.glob("transcripts/*/*.json")):
            parser.error(f"{run} holds no transcripts/<task>/*.json: run xicm-eval with transcripts=true")
        counts = count_run(run, args.near)
        calls = counts.pop("calls")
        print(f"{run}: {calls} replies with actions")
        for label, n in sorted(counts.items()):
            print(f"  {label:24s} {n:5d}  ({100 * n / calls:.0f} %)")


if __name__ == "__main__":
    main()
