import pytest

from xicm.report import summary as report


def _rows(task, seed, outcomes):
    return [{"task": task, "seed": seed, "episode": i, "success": s, "error_kind": None if s else "max_steps"} for i, s in enumerate(outcomes)]


# (successes, n) -> the interval of the closed form the reports used before scipy (z = 1.96)
WILSON_BEFORE = {
    (0, 1): (0.0, 0.7934567085261071),
    (1, 1): (0.20654329147389294, 1.0),
    (0, 25): (0.0, 0.13319649395317873),
    (25, 25): (0.8668035060468213, 1.0),
    (5, 10): (0.23658959361548731, 0.7634104063845126),
    (12, 25): (0.30031003928960015, 0.6650178204685269),
    (3, 75): (0.013695816001486477, 0.11113168623083756),
}


@pytest.mark.parametrize("successes, n", sorted(WILSON_BEFORE))
def test_wilson_interval_is_the_one_reports_always_had(successes, n):
    lo, hi = report.wilson_interval(successes, n)
    before_lo, before_hi = WILSON_BEFORE[successes, n]
    assert lo == pytest.approx(before_lo, rel=1e-13, abs=1e-15) and hi == pytest.approx(before_hi, rel=1e-13)
    assert (lo == 0.0) == (successes == 0) and (hi == 1.0) == (successes == n)


def test_wilson_interval_of_no_episodes_is_empty():
    assert report.wilson_interval(0, 0) == (0.0, 0.0)


def test_groups_are_means_over_tasks_then_mean_std_over_seeds():
    rows = (
        _rows("a", 0, [1, 1, 0, 0]) + _rows("a", 1, [1, 1, 1, 1])  # 50, 100
        + _rows("b", 0, [0, 0, 0, 0]) + _rows("b", 1, [1, 0, 0, 0])  # 0, 25
        + _rows("c", 0, [1, 1, 1, 1]) + _rows("c", 1, [1, 1, 1, 1])  # 100, 100
    )
    splits = {"a": "level1", "b": "level1", "c": "level2"}
    s = report.summarise(rows, splits, ["a", "b", "c"])
    by_task = {r["task"]: r for r in s["tasks"]}
    assert by_task["a"]["success"] == pytest.approx(75.0)
    assert by_task["a"]["std"] == pytest.approx(35.355, abs=1e-2)
    assert by_task["b"]["n"] == 8 and by_task["b"]["successes"] == 1
    assert by_task["b"]["errors"] == {"max_steps": 7}
    groups = {g["group"]: g for g in s["groups"]}
    assert groups["Level-1"]["success"] == pytest.approx((25 + 62.5) / 2)  # seed means 25, 62.5
    assert groups["Level-2"]["success"] == pytest.approx(100.0)
    assert groups["All"]["success"] == pytest.approx(((50 + 0 + 100) / 3 + (100 + 25 + 100) / 3) / 2)
    assert "Seen" not in groups
    table = report.markdown_table(s)
    assert "| a | level1 | 75.0 |" in table and "**Level-1**" in table
    csv_text = report.tasks_csv(s)
    assert csv_text.splitlines()[0].startswith("task,split,success_pct")


def test_task_order_follows_the_benchmark_not_the_rows():
    rows = _rows("z", 0, [1]) + _rows("a", 0, [0])
    s = report.summarise(rows, {"z": "seen", "a": "seen"}, ["z", "a"])
    assert [r["task"] for r in s["tasks"]] == ["z", "a"]


def test_seconds_per_episode_per_stage():
    rows = _rows("a", 0, [True, False])
    rows[0]["timings"] = {"reset": 1.0, "llm": 3.0, "total": 4.5}
    rows[1]["timings"] = {"reset": 2.0, "execute": 1.0, "total": 3.5}
    summary = report.summarise(rows, {"a": "level1"}, ["a"])
    assert summary["seconds"] == {"reset": 1.5, "llm": 1.5, "total": 4.0, "execute": 0.5}
    assert "Seconds per episode: reset 1.50, llm 1.50, execute 0.50; total 4.00." in report.markdown_table(summary)


def test_report_command_has_help_and_refuses_a_folder_without_runs(tmp_path, capsys):
    from xicm.report.cli import main as report_main

    with pytest.raises(SystemExit) as done:
        report_main(["--help"])
    usage = " ".join(capsys.readouterr().out.split())  # argparse wraps the usage line at the terminal's width
    assert done.value.code == 0 and "usage: xicm-report [-h] [--merge OUT_DIR] [--html] [--paired] [--results-page] [--episodes FIRST:STOP] [--pool PATH]" in usage
    with pytest.raises(SystemExit) as done:
        report_main([])
    assert done.value.code == 2 and "the following arguments are required: DIR" in capsys.readouterr().err
    with pytest.raises(SystemExit) as done:
        report_main([str(tmp_path)])
    err = capsys.readouterr().err
    assert done.value.code == 2 and err == f"xicm: error: {tmp_path} has no episodes.jsonl and run.json, nor a folder below it; pass an xicm-eval output folder\n"


def test_the_std_over_seeds_follows_the_runs_convention():
    """ddof 1 (ours, the sample std) or 0 (X-ICM's np.std), as the run's report.std_ddof says."""
    rows = [{"task": "a", "seed": s, "episode": 0, "success": s == 0} for s in (0, 1)]
    sample, population = (report.summarise(rows, {"a": "level1"}, ["a"], ddof) for ddof in (1, 0))
    assert sample["tasks"][0]["std"] == pytest.approx(70.71, abs=0.01)  # [100, 0] with ddof 1
    assert population["tasks"][0]["std"] == pytest.approx(50.0) and population["std_ddof"] == 0
    assert report.std_ddof({"config": {"report": {"std_ddof": 0}}}) == 0
    assert report.std_ddof({"config": {}}) == 1  # a run.json from before the option
