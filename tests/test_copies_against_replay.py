"""benchmarks/copies_against_replay.py splits the episodes of an anchored LLM run by its first reply
and pairs them with the replay's, on run folders written here in xicm-eval's layout."""

import json
import runpy
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = str(ROOT / "benchmarks/copies_against_replay.py")
DEMO_1 = "[[0, 0, 0, 9, 0, 36, 36, 1], [1, 0, 0, 5, 0, 36, 36, 0]]"
DEMO_2 = "[[1, 2, 0, 9, 0, 36, 36, 1], [0, 0, 0, 5, 0, 36, 36, 0]]"
PROMPT = ("['instruction': close the jar, {'lid': [37, 44, 17], 'jar': [57, 58, 21]}]>" + DEMO_1 + ", "
          "['instruction': close the jar, {'lid': [40, 30, 17], 'jar': [60, 20, 21]}]>" + DEMO_2 + ", "
          "['instruction': close the box, {'box': [57, 34, 17], 'lid': [54, 47, 21]}]>")
# episode: (the LLM's first reply, its success, the replay's first reply, its success)
EPISODES = {
    0: (DEMO_1, True, DEMO_1, True),                                                  # copy; replay keeps 0, 1
    1: (DEMO_1, False, "[[1, 0, 0, 9, 0, 36, 36, 1], [0, 0, 0, 5, 0, 36, 36, 0]]", True),  # copy; replay swaps
    2: (DEMO_1, True, "[[1, 3, 0, 9, 0, 36, 36, 1], [1, 0, 0, 5, 0, 36, 36, 0]]", False),
    3: (DEMO_2, True, DEMO_1, False),                                                 # the second demo's list
    4: ("[[0, 4, 4, 9, 0, 36, 36, 1]]", True, DEMO_1, False),                         # its own list
}


def _runs(tmp_path):
    llm, replay = tmp_path / "llm", tmp_path / "replay"
    (llm / "transcripts" / "close_box").mkdir(parents=True)
    replay.mkdir()
    for run, reply_at, success_at in ((llm, 0, 1), (replay, 2, 3)):
        rows = [{"task": "close_box", "seed": 0, "episode": e, "success": v[success_at], "responses": [v[reply_at]]}
                for e, v in EPISODES.items()]
        (run / "episodes.jsonl").write_text("".join(json.dumps(row) + "\n" for row in rows))
        (run / "run.json").write_text("{}")  # no config: every row counts
    for e, (reply, *_) in EPISODES.items():
        calls = [{"messages": [{"role": "user", "content": PROMPT}], "reply": reply}]
        (llm / "transcripts" / "close_box" / f"s0-e{e:04d}.json").write_text(json.dumps({"calls": calls}))
    return llm, replay


def _main(monkeypatch, capsys, *args):
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))  # as `python benchmarks/copies_against_replay.py` has it
    monkeypatch.setattr(sys, "argv", ["copies_against_replay.py", *map(str, args)])
    runpy.run_path(SCRIPT, run_name="__main__")
    return capsys.readouterr().out.splitlines()


def test_episodes_are_split_by_the_first_reply_and_paired_with_the_replay(tmp_path, monkeypatch, capsys):
    lines = _main(monkeypatch, capsys, *_runs(tmp_path))
    assert lines[2:] == [
        "| another demo's list | yes | 1 | 1 | 0 | 1 / 0 |",
        "| no whole demo list | yes | 1 | 1 | 0 | 1 / 0 |",
        "| the first demo's list | no | 2 | 1 | 1 | 1 / 1 |",
        "| the first demo's list | yes | 1 | 1 | 1 | 0 / 0 |",
    ]


def test_an_absolute_prompt_is_refused_with_one_sentence(tmp_path, monkeypatch, capsys):
    llm, replay = _runs(tmp_path)
    path = llm / "transcripts" / "close_box" / "s0-e0000.json"
    path.write_text(json.dumps({"calls": [{"messages": [{"role": "user", "content": "[[37, 44, 26, 0, 36, 36, 1]]"}],
                                           "reply": DEMO_1}]}))
    with pytest.raises(SystemExit) as done:
        _main(monkeypatch, capsys, llm, replay)
    assert "must use prompt.actions=anchored" in str(done.value.code)


def test_a_folder_without_episodes_is_refused_with_one_sentence(tmp_path, monkeypatch, capsys):
    llm, _ = _runs(tmp_path)
    with pytest.raises(SystemExit) as done:
        _main(monkeypatch, capsys, llm, tmp_path / "nothing")
    assert done.value.code == 2 and "holds no episodes.jsonl and run.json" in capsys.readouterr().err
