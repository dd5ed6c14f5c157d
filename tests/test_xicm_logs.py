"""X-ICM's own per-episode logs (src/xicm/report/xicm_logs.yaml): every name is one of our 41 tasks, every
transcribed seed agrees with the three records upstream printed for it, the per-task means give
back the paper's per-level figures, and bad entries are refused with one sentence."""

from pathlib import Path

import numpy as np
import pytest
import yaml

from xicm.report import table2, xicm_logs

ROOT = Path(__file__).resolve().parents[1]


def test_every_task_in_the_logs_is_one_of_our_41_tasks_and_each_run_covers_the_23_unseen():
    bench = yaml.safe_load((ROOT / "src/xicm/conf/benchmark/agnostos.yaml").read_text())
    ours = set(bench["tasks"]) | set(bench["pool_tasks"])
    assert len(ours) == 41
    runs = xicm_logs.runs()
    assert set(runs) == {"X-ICM (72B)", "X-ICM (7B)"} and len(xicm_logs.source()["commit"]) == 40
    for run in runs.values():
        summary_tasks = set(run["summary"]) - {"level1", "level2", "all"}
        for names in (set(run["scores"]), summary_tasks, set(run["episodes"])):
            assert names <= ours and names == set(bench["tasks"])
        assert all(len(v) == len(run["seeds"]) for v in run["scores"].values())


def test_each_transcribed_seed_matches_its_csv_footer_and_its_unseen_scores_line():
    checked = missing = 0
    for run in xicm_logs.runs().values():
        for task, per_seed in run["episodes"].items():
            assert list(per_seed) == run["seeds"], task
            for i, seed in enumerate(run["seeds"]):
                if per_seed[seed] is None:
                    missing += 1
                    continue
                episodes, footer = xicm_logs.parse_episodes(per_seed[seed])
                score, mean_steps, total = footer.split(",")
                steps = [s for s, _ in episodes]
                rate = 100 * sum(ok for _, ok in episodes) / len(episodes)
                assert len(episodes) == 25 and sum(steps) == int(total), (task, seed)
                assert rate == float(score) == run["scores"][task][i], (task, seed)
                assert sum(steps) / 25 == pytest.approx(float(mean_steps), abs=0.005), (task, seed)
                checked += 1
    assert (checked, missing) == (23 * 6 - 1 + 23 * 3, 1)  # 72B put_toilet_roll_on_stand seed 75 has no csv


def test_per_task_means_reproduce_upstreams_summary_and_the_papers_levels():
    paper = {row["name"]: row for row in yaml.safe_load(table2.PAPER_TABLE.read_text())["rows"]}
    table = table2.paper_table()
    levels = {"level1": table["level1"], "level2": table["level2"], "all": [*table["level1"], *table["level2"]]}
    for name, run in xicm_logs.runs().items():
        for task, s in xicm_logs.task_success(run).items():
            assert [s["mean"], s["std"]] == pytest.approx(run["summary"][task], abs=0.006), (name, task)
        got = xicm_logs.level_means(run, levels)
        for level, value in got.items():
            assert value == pytest.approx(run["summary"][level][0], abs=0.006), (name, level)
            assert value == pytest.approx(paper[name][level], abs=0.05), (name, level)  # the published one decimal


def test_the_paper_rows_get_per_task_cells_from_the_logs_and_no_other_row_does():
    rows = {row["name"]: row for row in table2.paper_table()["rows"]}
    assert rows["X-ICM (72B)"]["tasks"]["close_fridge"] == pytest.approx(12.67, abs=0.01)
    assert rows["X-ICM (7B)"]["tasks"]["take_lid_off_saucepan"] == pytest.approx(20.0)
    assert "mean of 6 seeds (std 5.4); of 150 episodes 85 % failed early" in rows["X-ICM (72B)"]["task_notes"]["close_fridge"]
    assert rows["VoxPoser"]["tasks"] == {} and rows["X-ICM (72B), random selection"]["tasks"] == {}


def test_episode_ends_split_failures_into_early_ends_and_full_budgets():
    run = {"episodes": {"t": {0: "25 3 4+ 25+ | 50.0,14.25,57", 1: None, 2: "1 | 0.0,1.0,1"}}}
    assert xicm_logs.episode_ends(run)["t"] == {"episodes": 5, "successes": 2, "early": 2, "full": 1,
                                                 "mean_steps": pytest.approx(np.mean([25, 3, 4, 25, 1]))}
    ends = xicm_logs.episode_ends(xicm_logs.runs()["X-ICM (72B)"])
    assert ends["close_fridge"]["episodes"] == 150 and ends["close_fridge"]["successes"] == 19


@pytest.mark.parametrize("text, message", [
    ("25 3 4+", "has no '|' before the csv footer"),
    ("25 x | 0.0,1,1", "token 'x' is not a step count 1..25"),
    ("26 | 0.0,26,26", "token '26' is not a step count 1..25"),
])
def test_a_bad_entry_is_refused_with_one_sentence(text, message):
    with pytest.raises(ValueError, match=message):
        xicm_logs.parse_episodes(text)


def test_the_comparison_script_sets_upstream_beside_a_committed_row(monkeypatch, capsys):
    import runpy
    import sys

    row = ROOT / "results/agnostos/xicm-paper-language-k4-actions/nearest_demo"
    monkeypatch.setattr(sys, "argv", ["xicm_logs_compare.py", str(row)])
    runpy.run_path(str(ROOT / "benchmarks/xicm_logs_compare.py"), run_name="__main__")
    lines = capsys.readouterr().out.splitlines()
    fridge = next(line for line in lines if line.startswith("| close_fridge |"))
    assert fridge.startswith("| close_fridge | 1 | 12.7 | 22.7 | 47 (7/15) | easier here | 85 / 3 · 3.4 |")
    assert lines[-1].startswith("| **all episodes** | | 30 | 24 | 7 (23/345) |")


def test_the_comparison_script_refuses_a_folder_that_is_not_a_run(tmp_path, monkeypatch, capsys):
    import runpy
    import sys

    monkeypatch.setattr(sys, "argv", ["xicm_logs_compare.py", str(tmp_path)])
    with pytest.raises(SystemExit) as done:
        runpy.run_path(str(ROOT / "benchmarks/xicm_logs_compare.py"), run_name="__main__")
    assert done.value.code == 2 and f"{tmp_path} is not a run folder: it needs episodes.jsonl and run.json" in capsys.readouterr().err
