"""wandb runs grouped by experiment: the config key, the offline run's recorded group, job type
and tags (read back from the run file wandb wrote), and the media a run logs."""

from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_module
from hydra.core.hydra_config import HydraConfig

import xicm.conf  # noqa: F401  (registers the configs' resolvers)
from xicm.core.results.run_dir import short_name
from xicm.core.results.tracking import WANDB_LABEL_LIMIT, Tracker, current_job_overrides


def _records(path: Path) -> list[bytes]:
    """The protobuf records of a .wandb file (a ':W&B' header, then LevelDB-log blocks)."""
    data = path.read_bytes()
    assert data[:4] == b":W&B"
    pos, block, parts, out = 7, 32768, [], []
    while pos + 7 <= len(data):
        if block - pos % block < 7:  # a block's tail too short for a record header is padding
            pos += block - pos % block
            continue
        length, kind = int.from_bytes(data[pos + 4 : pos + 6], "little"), data[pos + 6]
        payload, pos = data[pos + 7 : pos + 7 + length], pos + 7 + length
        if kind == 1:  # full
            out.append(payload)
        elif kind in (2, 3):  # first, middle
            parts.append(payload)
        elif kind == 4:  # last
            out.append(b"".join(parts) + payload)
            parts = []
    return out


def offline_run_record(out_dir: Path):
    """The RunRecord (group, job_type, tags, ...) of the one offline wandb run under out_dir."""
    from wandb.proto import wandb_internal_pb2 as pb

    files = list(Path(out_dir).glob("wandb/offline-run-*/run-*.wandb"))
    assert len(files) == 1, files
    for raw in _records(files[0]):
        record = pb.Record()
        record.ParseFromString(raw)
        if record.WhichOneof("record_type") == "run":
            return record.run
    raise AssertionError(f"no run record in {files[0]}")


def _hydra_cfg(overrides):
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        cfg = compose("config", overrides=overrides, return_hydra_config=True)
    HydraConfig.instance().set_config(cfg)
    return cfg


@pytest.mark.parametrize(
    "overrides, group",
    [
        ([], "smoke"),  # no experiment: the benchmark
        (["benchmark=level1"], "level1"),
        (["+experiment=ablation_k"], "ablation_k"),  # the preset, not its benchmark (agnostos)
        (["+experiment=ablation_k", "tracking.group=mine"], "mine"),
    ],
)
def test_group_is_the_experiment_preset_else_the_benchmark(overrides, group):
    assert _hydra_cfg(overrides).tracking.group == group


def test_job_overrides_leave_out_the_bookkeeping_keys():
    _hydra_cfg(["+experiment=smoke", "policy.k=6", "progress=false", "paths.data=/tmp/x", "tracking.mode=offline"])
    assert current_job_overrides() == ["+experiment=smoke", "policy.k=6"]


def test_offline_run_records_group_job_type_and_tags(tmp_path, monkeypatch):
    monkeypatch.setenv("WANDB_MODE", "offline")
    long_override = "benchmark.tasks=[" + ",".join(f"task_{i}" for i in range(20)) + "]"
    tracker = Tracker(
        mode="offline", project="xicm-test", run_name="ablation_k-job", out_dir=str(tmp_path), config={"k": 6},
        tags=["policy.k=6", long_override], group="ablation_k", job_type="policy.k=6",
    )
    tracker.log({"success": 1})
    assert tracker.finish().startswith("wandb (offline): ")
    run = offline_run_record(tmp_path)
    assert (run.run_group, run.job_type, run.display_name) == ("ablation_k", "policy.k=6", "ablation_k-job")
    label = short_name(long_override, WANDB_LABEL_LIMIT)
    assert list(run.tags) == ["policy.k=6", label]
    assert len(label) == 64 and label != short_name(long_override + "x", WANDB_LABEL_LIMIT)


def test_for_job_uses_the_config_and_the_hydra_overrides(tmp_path, monkeypatch):
    monkeypatch.setenv("WANDB_MODE", "offline")
    cfg = _hydra_cfg(["+experiment=ablation_k", "policy.k=6", "progress=false"])
    Tracker.for_job(cfg, tmp_path, config={}).finish()
    run = offline_run_record(tmp_path)
    assert (run.run_group, run.job_type, list(run.tags)) == ("ablation_k", "+experiment=ablation_k,policy.k=6", ["+experiment=ablation_k", "policy.k=6"])
    assert run.display_name == "agnostos-nearest_demo-dynamics_xicm-k6"  # run_name: benchmark, llm, retriever, K


def test_run_media_logs_the_plots_and_the_rows_videos(tmp_path, monkeypatch):
    import imageio.v2 as imageio

    monkeypatch.setenv("WANDB_MODE", "offline")
    imageio.imwrite(tmp_path / "sweep.png", np.zeros((8, 8, 3), np.uint8))
    video = tmp_path / "videos" / "open_drawer" / "s0-e0000-FAIL.mp4"
    video.parent.mkdir(parents=True)
    imageio.mimwrite(video, [np.full((16, 16, 3), i * 20, np.uint8) for i in range(5)], fps=5, macro_block_size=1)
    rows = [
        {"task": "open_drawer", "extra": {"video": "videos/open_drawer/s0-e0000-FAIL.mp4"}},
        {"task": "open_drawer", "extra": {"video": "videos/open_drawer/gone.mp4"}},  # deleted since: skipped
        {"task": "push_buttons", "extra": {"video_error": "OSError: disk full"}},
    ]
    tracker = Tracker(mode="offline", project="xicm-test", run_name="media", out_dir=str(tmp_path), config={})
    tracker.log_run_media(rows, tmp_path)
    tracker.finish()
    files = next((tmp_path / "wandb").glob("offline-run-*/files"))
    assert len(list(files.rglob("media/images/**/*.png"))) == 1
    assert [p.suffix for p in files.rglob("media/videos/**/*")if p.is_file()] == [".mp4"]
