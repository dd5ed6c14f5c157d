"""benchmarks/reply_copies.py sorts recorded replies by what they copy from the prompt's demos,
on a run folder written here in the transcripts' layout."""

import json
import re
import runpy
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = str(ROOT / "benchmarks/reply_copies.py")
PROMPT = ("['instruction': close the jar, {'lid': [37, 44, 17], 'jar': [57, 58, 21]}]>"
          "[[37, 44, 26, 0, 36, 36, 1], [57, 58, 26, 0, 36, 36, 0]], "
          "['instruction': close the jar, {'lid': [40, 30, 17], 'jar': [60, 20, 21]}]>"
          "[[40, 30, 26, 0, 36, 36, 1], [60, 20, 26, 0, 36, 36, 0]], "
          "['instruction': close the jar, {'lid': [57, 34, 17], 'jar': [54, 47, 21]}]>")


def _run(tmp_path, replies):
    calls = [{"messages": [{"role": "system", "content": "x"}, {"role": "user", "content": PROMPT}], "reply": r}
             for r in replies]
    folder = tmp_path / "transcripts" / "close_jar"
    folder.mkdir(parents=True)
    (folder / "s0-e0000.json").write_text(json.dumps({"task": "close_jar", "seed": 0, "episode": 0, "calls": calls}))
    return tmp_path


def _main(monkeypatch, capsys, *args):
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))  # as `python benchmarks/reply_copies.py` has it
    monkeypatch.setattr(sys, "argv", ["reply_copies.py", *map(str, args)])
    runpy.run_path(SCRIPT, run_name="__main__")
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].endswith(": 5 replies with actions")
    return {m[1]: int(m[2]) for m in (re.match(r"\s+(.+?)\s+(\d+)\s+\(", line) for line in lines[1:])}


def test_replies_are_sorted_by_what_they_copy_and_whether_they_reach_the_query(tmp_path, monkeypatch, capsys):
    run = _run(tmp_path, [
        "[[37, 44, 26, 0, 36, 36, 1], [57, 58, 26, 0, 36, 36, 0]]",   # demo 1, verbatim
        "[[60, 20, 26, 0, 36, 36, 0], [37, 44, 26, 0, 36, 36, 1]]",   # both copied, no whole list
        "[[57, 33, 26, 0, 36, 36, 1], [54, 47, 26, 0, 36, 36, 0]]",   # moved to the query's lid and jar
        "[[57, 33, 26, 0, 36, 36, 1], [37, 44, 26, 0, 36, 36, 1]]",   # half moved, half copied
        "[[37, 44, 26, 0, 36, 36, 1], [57, 58, 26, 0, 36, 36, 1]]",   # demo 1's start, its own end
        "no action here",
    ])
    counts = _main(monkeypatch, capsys, run)
    assert counts == {"all copied": 1, "at a query object": 2, "equals demo 1 of 2": 1, "none copied": 1, "some copied": 2}


ANCHORED_PROMPT = ("['instruction': close the jar, {'lid': [37, 44, 17], 'jar': [57, 58, 21]}]>"
                   "[[0, 0, 0, 9, 0, 36, 36, 1], [1, 0, 0, 5, 0, 36, 36, 0]], "
                   "['instruction': close the jar, {'lid': [57, 34, 17], 'jar': [54, 47, 21]}]>")


def test_anchored_replies_are_sorted_the_same_way(tmp_path, monkeypatch, capsys):
    calls = [{"messages": [{"role": "user", "content": ANCHORED_PROMPT}], "reply": r} for r in [
        "[[0, 0, 0, 9, 0, 36, 36, 1], [1, 0, 0, 5, 0, 36, 36, 0]]",    # the demo, verbatim: on the query's objects
        "[[1, 0, 0, 5, 0, 36, 36, 0]]",                                # copied, at the jar
        "[[0, 20, 0, 9, 0, 36, 36, 1]]",                               # 20 voxels off the lid
        "[[0, 3, 0, 9, 0, 36, 36, 1], [0, 0, 1, 9, 0, 36, 36, 1]]",   # new, one of them at the lid
        "[[1, 0, 0, 5, 0, 36, 36, 0], [0, 9, 9, 9, 0, 36, 36, 1]]",   # half copied
    ]]
    folder = tmp_path / "transcripts" / "close_jar"
    folder.mkdir(parents=True)
    (folder / "s0-e0000.json").write_text(json.dumps({"calls": calls}))
    counts = _main(monkeypatch, capsys, tmp_path)
    assert counts == {"all copied": 1, "at a query object": 4, "equals demo 1 of 1": 1, "none copied": 2, "some copied": 1}


def test_a_folder_without_transcripts_is_refused_with_one_sentence(tmp_path, monkeypatch, capsys):
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    monkeypatch.setattr(sys, "argv", ["reply_copies.py", str(tmp_path)])
    with pytest.raises(SystemExit) as done:
        runpy.run_path(SCRIPT, run_name="__main__")
    assert done.value.code == 2 and "holds no transcripts/<task>/*.json" in capsys.readouterr().err
