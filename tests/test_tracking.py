from pathlib import Path

from xicm.core.results.tracking import Tracker


def test_disabled_tracker_writes_nothing(tmp_path):
    t = Tracker(mode="disabled", project="xicm", run_name="x", out_dir=str(tmp_path), config={})
    t.log({"a": 1})
    assert not t.enabled and t.finish() is None and list(tmp_path.iterdir()) == []


def test_offline_run_is_written_to_the_output_folder(tmp_path, monkeypatch):
    monkeypatch.delenv("WANDB_MODE", raising=False)
    t = Tracker(mode="offline", project="xicm-test", run_name="unit", out_dir=str(tmp_path), config={"k": 2, "plugins": [{"name": "p"}]})
    assert t.enabled
    t.log({"success": 1, "steps": 3})
    t.log_table("tasks", ["task", "success"], [["open_drawer", 50.0]])
    t.summary({"success/All": 50.0})
    note = t.finish()
    assert note.startswith("wandb (offline): ") and "wandb sync" in note
    runs = list((tmp_path / "wandb").glob("offline-run-*"))
    assert len(runs) == 1 and list(runs[0].glob("run-*.wandb"))
    assert Path(note.split(": ", 1)[1].split(" (")[0]) == runs[0]


def test_a_run_logs_the_table2_table_and_its_level_bars(tmp_path, monkeypatch):
    """eval_job's summary logging, offline: the Table-2 table (ours beside the paper's rows) and
    the per-level bar chart's data are media files of the run."""
    import json

    from xicm.core.assembly.eval_job import _track_summary
    from xicm.report.summary import summarise

    monkeypatch.delenv("WANDB_MODE", raising=False)
    rows = [{"task": t, "seed": 0, "episode": i, "success": ok}
            for t, outcomes in (("close_fridge", [1, 1]), ("unplug_charger", [1, 0])) for i, ok in enumerate(outcomes)]
    splits = {"close_fridge": "level1", "unplug_charger": "level2"}
    t = Tracker(mode="offline", project="xicm-test", run_name="unit", out_dir=str(tmp_path), config={})
    _track_summary(t, summarise(rows, splits, list(splits)), rows, "agnostos-mine", "ours, sapien")
    t.finish()
    media = next((tmp_path / "wandb").glob("offline-run-*")) / "files/media/table"
    table = json.loads(next(media.glob("table2_[0-9]*.table.json")).read_text())
    assert table["columns"][:3] == ["method", "source", "put_toilet_roll_on_stand"] and len(table["columns"]) == 2 + 23 + 4
    assert table["data"][0][:2] == ["agnostos-mine", "ours, sapien"] and table["data"][0][-4:] == [100.0, 50.0, 75.0, 0.0]
    assert {row[1] for row in table["data"][1:]} == {"paper, RLBench/CoppeliaSim"} and len(table["data"]) == 6
    bars = json.loads(next(media.glob("table2_levels_table_*.table.json")).read_text())
    assert bars == {"columns": ["level", "success"], "data": [["Level-1", 100.0], ["Level-2", 50.0], ["All", 75.0]]}
