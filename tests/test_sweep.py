"""xicm-report over several runs: the swept config keys, one row per run, a plot."""

import csv
import json
import re

import pytest

from xicm.report.cli import main as report_main
from xicm.core.results.run_dir import find_runs
from xicm.report.sweep import collect_sweep

SPLITS = {"a": "level1", "b": "level2"}


def make_run(folder, noise, retriever, outcomes):
    """outcomes: {(task, seed): [bool, ...]}"""
    folder.mkdir(parents=True)
    config = {"detector": {"name": "noisy_oracle", "noise_cm": noise}, "retriever": {"name": retriever},
              "paths": {"data": str(folder)}, "seeds": [0, 1]}
    (folder / "run.json").write_text(json.dumps({"tasks": ["a", "b"], "splits": SPLITS, "config": config}))
    with open(folder / "episodes.jsonl", "w") as f:
        for (task, seed), results in outcomes.items():
            for i, ok in enumerate(results):
                f.write(json.dumps({"task": task, "seed": seed, "episode": i, "success": ok, "steps": 1}) + "\n")


def test_sweep_table_csv_and_plot(tmp_path, capsys):
    root = tmp_path / "multirun"
    for noise, rate in ((0, 1.0), (2, 0.5), (8, 0.0)):
        ok = [i < 4 * rate for i in range(4)]
        make_run(root / f"detector.noise_cm={noise}", noise, "language",
                 {("a", 0): ok, ("a", 1): ok, ("b", 0): [True] * 4, ("b", 1): [False] * 4})
    runs = find_runs(root)
    sweep = collect_sweep(runs)
    assert sweep["axes"] == ["detector.noise_cm"]  # paths.* differs too but is not an axis
    assert [r["detector.noise_cm"] for r in sweep["rows"]] == [0, 2, 8]
    assert sweep["rows"][1]["groups"]["Level-1"] == (50.0, 0.0, 2)
    assert sweep["rows"][0]["groups"]["Level-2"][:2] == (50.0, pytest.approx(70.71, abs=0.01))  # 100 % on seed 0, 0 % on seed 1 (sample std)
    report_main([str(root)])
    out = capsys.readouterr().out
    assert "## sweep over detector.noise_cm" in out
    assert "| 2 | 50.0 (0.0) | 50.0 (70.7) | 50.0 (35.4) | 16 |" in out
    rows = list(csv.DictReader(open(root / "sweep.csv")))
    assert [r["All_mean"] for r in rows] == ["75.00", "50.00", "25.00"]
    assert (root / "sweep.png").read_bytes()[:4] == b"\x89PNG"


def test_two_axes_plot_one_line_per_other_value(tmp_path):
    root = tmp_path / "grid"
    for noise in (0, 4):
        for retriever in ("random", "language"):
            make_run(root / f"{noise}-{retriever}", noise, retriever, {("a", 0): [noise == 0, True]})
    sweep = collect_sweep(find_runs(root))
    assert sweep["axes"] == ["detector.noise_cm", "retriever.name"]
    assert [(r["detector.noise_cm"], r["retriever.name"]) for r in sweep["rows"]] == [
        (0, "language"), (0, "random"), (4, "language"), (4, "random")]
    report_main([str(root)])
    assert (root / "sweep.png").stat().st_size > 1000


def test_merge_runs_that_cover_different_tasks(tmp_path, capsys):
    a, b = tmp_path / "part1", tmp_path / "part2"
    make_run(a, 0, "language", {("a", 0): [True, False]})
    make_run(b, 0, "language", {("b", 0): [True, True]})
    meta = json.loads((b / "run.json").read_text())
    meta["tasks"], meta["config"]["paths"]["data"] = ["b"], "elsewhere"
    (b / "run.json").write_text(json.dumps(meta))
    report_main(["--merge", str(tmp_path / "all"), str(a), str(b)])
    out = capsys.readouterr().out
    assert "| **All** (2 tasks) | | **75.0** |" in out
    merged = json.loads((tmp_path / "all" / "run.json").read_text())
    assert merged["merged_from"] == [str(a), str(b)] and merged["tasks"] == ["a", "b"]
    assert len((tmp_path / "all" / "episodes.jsonl").read_text().splitlines()) == 4


def test_merge_refuses_other_configs_and_duplicate_episodes(tmp_path, capsys):
    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    make_run(a, 0, "language", {("a", 0): [True]})
    make_run(b, 2, "language", {("b", 0): [True]})
    make_run(c, 0, "language", {("a", 0): [False]})
    for other, why in ((b, r"another config than .* \(detector.noise_cm\)"), (c, r"episode \('a', 0, 0\) is in both")):
        with pytest.raises(SystemExit):
            report_main(["--merge", str(tmp_path / "out"), str(a), str(other)])
        assert re.search(why, capsys.readouterr().err)


def test_reports_count_only_the_episodes_the_run_asks_for(tmp_path, capsys):
    """A run resumed with fewer episodes keeps the earlier rows in its file; reports ignore them."""
    run = tmp_path / "run"
    make_run(run, 0, "language", {("a", 0): [True, False, False]})
    meta = json.loads((run / "run.json").read_text())
    meta["config"].update(seeds=[0], episodes=1)
    (run / "run.json").write_text(json.dumps(meta))
    report_main([str(run)])
    assert "| a | level1 | 100.0 | - | 1 |" in capsys.readouterr().out
