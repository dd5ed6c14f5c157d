from pathlib import Path

from xicm.core.tracking import Tracker


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
