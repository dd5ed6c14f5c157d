import pytest

from xicm.core import report


def _rows(task, seed, outcomes):
    return [{"task": task, "seed": seed, "episode": i, "success": s, "error_kind": None if s else "max_steps"} for i, s in enumerate(outcomes)]


def test_wilson_interval_known_values():
    lo, hi = report.wilson_interval(5, 10)
    assert lo == pytest.approx(0.2366, abs=1e-3) and hi == pytest.approx(0.7634, abs=1e-3)
    assert report.wilson_interval(0, 0) == (0.0, 0.0)
    lo, hi = report.wilson_interval(0, 25)
    assert lo == 0.0 and 0.1 < hi < 0.15


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
