"""benchmarks/selection_ablation_table.py counts the LLM column of the selection ablation on the
episodes its cells share, on run folders written here in xicm-eval's layout."""

import json
import runpy
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = str(ROOT / "benchmarks/selection_ablation_table.py")
LEVEL1, LEVEL2 = "put_toilet_roll_on_stand", "take_usb_out_of_computer"
# per cell, the successes of episodes 0-3 of each task (Level-1 task first)
LLM = {
    "dynamics": ([1, 1, 0, 1], [1, 0, 0, 0]),
    "random": ([1, 0, 0, 0], [0, 0, 1, 0]),
    "dynamics_xicm": ([0, 1, 0, 0], [0, 0, 0, 0]),
    "language": ([0, 0, 0, 0], [0, 0, 1, 1]),
}
REPLAY = {
    "dynamics": ([1, 1, 1, 1], [0, 0, 0, 0]),
    "random": ([0, 0, 0, 0], [0, 0, 0, 0]),
    "dynamics_xicm": ([0, 1, 0, 0], [0, 0, 0, 0]),
    "language": ([1, 0, 0, 0], [0, 0, 1, 1]),
}


def _cell(path: Path, outcomes, episodes: int = 4) -> None:
    path.mkdir(parents=True)
    rows = [{"task": task, "seed": 0, "episode": e, "success": bool(won[e])}
            for task, won in zip((LEVEL1, LEVEL2), outcomes) for e in range(episodes)]
    (path / "episodes.jsonl").write_text("".join(json.dumps(row) + "\n" for row in rows))
    (path / "run.json").write_text("{}")  # no config: every row counts


def _ablation(tmp_path: Path) -> Path:
    for selection in LLM:
        _cell(tmp_path / f"{selection}-qwen2_5_coder_0_5b", LLM[selection])
        _cell(tmp_path / f"{selection}-nearest_demo", REPLAY[selection])
    return tmp_path


def _main(monkeypatch, capsys, *args):
    monkeypatch.setattr(sys, "argv", ["selection_ablation_table.py", *map(str, args)])
    runpy.run_path(SCRIPT, run_name="__main__")
    return capsys.readouterr().out.splitlines()


def test_the_column_is_counted_on_the_common_episodes(tmp_path, monkeypatch, capsys):
    lines = _main(monkeypatch, capsys, _ablation(tmp_path))
    assert lines[0] == "8 common episodes (4 Level-1, 4 Level-2); episode indices [0, 1, 2, 3]"
    rows = [line for line in lines if line.startswith("| `")]
    # dynamics 4 of 8 against random's 2: only dynamics on (L1, 1), (L1, 3), (L2, 0); only random on (L2, 2)
    assert rows[0].startswith("| `dynamics` | 4 (50.0 %) | ") and rows[0].endswith(
        " | 3 (75.0 %) | 1 (25.0 %) | 3 / 1 | 0.625 | 4 (50.0 %) |")
    assert rows[1].startswith("| `random` | 2 (25.0 %) | ") and rows[1].endswith(" | - | - | 0 (0.0 %) |")
    assert "  language: 2 / 3; 0 / 1; p = 1" in lines  # the LLM against its own replay
    assert "  dynamics: 4 / 0; p = 0.125" in lines     # the replay against random's replay
    assert lines[-2:] == ["  0-1: 3, 1, 1, 0", "  2-3: 1, 1, 0, 2"]


def test_episodes_one_cell_lacks_are_left_out(tmp_path, monkeypatch, capsys):
    root = _ablation(tmp_path)
    rows = (root / "language-qwen2_5_coder_0_5b" / "episodes.jsonl").read_text().splitlines()
    (root / "language-qwen2_5_coder_0_5b" / "episodes.jsonl").write_text("\n".join(rows[:3] + rows[4:7]) + "\n")
    lines = _main(monkeypatch, capsys, root)
    assert lines[0] == "6 common episodes (3 Level-1, 3 Level-2); episode indices [0, 1, 2]"


def test_a_replay_cell_short_of_the_column_is_one_sentence(tmp_path, monkeypatch, capsys):
    root = _ablation(tmp_path)
    (root / "random-nearest_demo" / "episodes.jsonl").write_text("")
    with pytest.raises(SystemExit, match="the replay cells of random lack some of the LLM column's episodes"):
        _main(monkeypatch, capsys, root)
