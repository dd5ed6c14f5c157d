"""Rollout videos and LLM transcripts on the real simulator: what the files hold, their names,
and that a broken video never changes an episode's outcome."""

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import imageio.v2 as imageio
import pytest

from xicm.core.results import video as video_module
from xicm.plugins.policies.xicm.policy import XICMPolicy
from xicm.core.execution.episode import run_episode
from xicm.core.contracts.interfaces import LLM
from xicm.core.assembly.plugins import get_registry
from xicm.report.summary import media_lines
from xicm.core.contracts.types import Demo, KeyAction
from xicm.core.results.video import VideoSettings
from xicm.plugins.policies.oracle import OraclePolicy

TASK = "push_buttons"  # the oracle solves it in ~8 key actions, ~90 frames


def _frames(path: Path) -> int:
    reader = imageio.get_reader(str(path))
    try:
        return sum(1 for _ in reader)
    finally:
        reader.close()


def test_oracle_episode_writes_a_pass_video_with_every_kth_control_frame(sim, tmp_path):
    settings = VideoSettings(tmp_path, camera="front", fps=10, every=7)
    result = run_episode(sim, OraclePolicy(sim), TASK, 0, 0, video=settings)
    assert result.success and result.error_kind is None
    path = tmp_path / "videos" / TASK / "s0-e0000-PASS.mp4"
    assert result.extra["video"] == "videos/push_buttons/s0-e0000-PASS.mp4" and path.is_file()
    # the reset picture, every 7th frame, and the last frame if it was not a 7th one
    expected = 1 + math.ceil(sim.controller.frames / 7)
    assert sim.controller.frames % 7 and result.extra["video_frames"] == expected == _frames(path)
    reader = imageio.get_reader(str(path))
    assert reader.get_meta_data()["size"] == (128, 128) and reader.get_meta_data()["fps"] == 10
    reader.close()
    assert sorted(p.name for p in path.parent.iterdir()) == [path.name]  # no temporary file left
    assert 0 < result.timings["video"] and 0 < result.timings["execute"] < result.timings["total"] - result.timings["video"]
    frames = sim.controller.frames
    plain = run_episode(sim, OraclePolicy(sim), TASK, 0, 0)  # rendering does not change the physics
    assert (plain.success, plain.steps, sim.controller.frames) == (result.success, result.steps, frames)


def test_a_failed_episode_video_says_fail_and_a_rerun_replaces_it(sim, tmp_path):
    settings = VideoSettings(tmp_path, camera="front", fps=20, every=4)
    failed = run_episode(sim, OraclePolicy(sim), TASK, 0, 1, max_steps=1, video=settings)
    assert not failed.success and failed.extra["video"].endswith("s0-e0001-FAIL.mp4")
    assert _frames(tmp_path / failed.extra["video"]) == failed.extra["video_frames"] >= 2
    again = run_episode(sim, OraclePolicy(sim), TASK, 0, 1, video=settings)  # e.g. a resumed, re-run episode
    assert again.success
    assert sorted(p.name for p in (tmp_path / "videos" / TASK).iterdir()) == ["s0-e0001-PASS.mp4"]


def test_a_simulator_without_frame_callbacks_gets_one_picture_per_key_action(sim, tmp_path, monkeypatch):
    monkeypatch.setattr(sim, "set_frame_callback", lambda callback: False)
    result = run_episode(sim, OraclePolicy(sim), TASK, 0, 0, video=VideoSettings(tmp_path, camera="front", fps=20, every=1))
    assert result.success and result.extra["video_frames"] == 1 + result.steps == _frames(tmp_path / result.extra["video"])


class _DiskFullAfter:
    """A real ffmpeg writer that fails on its n-th picture, as a full disk would."""

    def __init__(self, real, n):
        self.real, self.n = real, n

    def append_data(self, rgb):
        self.n -= 1
        if self.n == 0:
            raise OSError(28, "No space left on device")
        self.real.append_data(rgb)

    def close(self):
        self.real.close()


@pytest.mark.parametrize("failure", ["disk_full", "no_encoder"])
def test_a_broken_video_writer_leaves_the_episode_unchanged_and_is_recorded(sim, tmp_path, monkeypatch, capsys, failure):
    plain = run_episode(sim, OraclePolicy(sim), TASK, 0, 0)
    real_get_writer = imageio.get_writer
    if failure == "disk_full":
        broken = lambda *a, **k: _DiskFullAfter(real_get_writer(*a, **k), 5)
    else:
        def broken(*a, **k):
            raise RuntimeError("No ffmpeg exe could be found. Install ffmpeg on your system")
    monkeypatch.setattr(imageio, "get_writer", broken)
    monkeypatch.setattr(video_module, "_warned", False)
    results = [run_episode(sim, OraclePolicy(sim), TASK, 0, 0, video=VideoSettings(tmp_path, camera="front", fps=20, every=1)) for _ in range(2)]
    for r in results:
        assert (r.success, r.steps, r.error_kind) == (plain.success, plain.steps, plain.error_kind) == (True, plain.steps, None)
        assert "video" not in r.extra
        assert ("No space left" if failure == "disk_full" else "No ffmpeg exe") in r.extra["video_error"]
    assert not list(tmp_path.rglob("*.mp4"))  # the partial file is gone
    warnings = [line for line in capsys.readouterr().err.splitlines() if "rollout video not recorded" in line]
    assert len(warnings) == 1  # once per process, not per episode


def test_an_unknown_camera_is_a_video_error_not_an_episode_error(sim, tmp_path):
    result = run_episode(sim, OraclePolicy(sim), TASK, 0, 0, video=VideoSettings(tmp_path, camera="ceiling", fps=20, every=1))
    assert result.success and "ceiling" in result.extra["video_error"]


def test_video_settings_come_from_the_video_keys(tmp_path):  # their bad values: tests/test_config_schema.py
    from omegaconf import OmegaConf

    video = {"enabled": True, "camera": "overhead", "fps": 12.5, "every": 3}
    assert VideoSettings.from_config(OmegaConf.create(video), tmp_path) == VideoSettings(tmp_path, "overhead", 12.5, 3)
    assert VideoSettings.from_config(OmegaConf.create({**video, "enabled": False}), tmp_path) is None


class _SameReply(LLM):
    deterministic = True

    def complete(self, prompt):
        return "[[40, 50, 40, 0, 36, 36, 1]]"  # reachable, solves nothing


def test_each_episode_transcript_holds_every_prompt_and_reply(sim, tmp_path):
    reg = get_registry()
    down = KeyAction((0.1, 0.0, 1.0), (0.0, 1.0, 0.0, 0.0), True)
    demo = Demo("close_jar/s0/e0000", "close_jar", "close the jar", 0, 0, {"jar": (0.1, 0.0, 0.8)}, [down])
    policy = XICMPolicy(
        reg.create("detector", {"name": "oracle"}), reg.create("retriever", {"name": "random"}, encoder=None),
        reg.create("prompt", {"name": "xicm"}), _SameReply(), [demo], sim.workspace, k=1,
    )
    result = run_episode(sim, policy, TASK, 0, 2, max_steps=2, transcripts_dir=tmp_path)
    assert result.error_kind == "max_steps" and len(result.responses) == 2
    assert result.extra["transcript"] == "transcripts/push_buttons/s0-e0002.json"
    saved = json.loads((tmp_path / result.extra["transcript"]).read_text())
    assert (saved["task"], saved["seed"], saved["episode"]) == (TASK, 0, 2)
    assert [c["reply"] for c in saved["calls"]] == result.responses
    assert all("close the jar" in json.dumps(c["messages"]) and c["messages"][-1]["content"] for c in saved["calls"])
    row = json.dumps(result.__dict__)
    assert "close the jar" not in row  # the prompts stay out of episodes.jsonl
    lines = media_lines([{"task": TASK, "extra": result.extra}], tmp_path)
    assert any("transcripts/<task>" in line and f"{TASK} 1 episodes" in line for line in lines)


@pytest.mark.slow
@pytest.mark.subprocess
def test_xicm_eval_records_videos_lists_them_and_logs_them_to_an_offline_wandb_group(tmp_path):
    from test_tracking_group import offline_run_record

    out = tmp_path / "run"
    command = [
        str(Path(sys.executable).parent / "xicm-eval"), "+experiment=smoke", "policy=oracle", f"benchmark.tasks=[{TASK}]",
        "seeds=[0]", "episodes=1", "video.enabled=true", "video.every=3", f"paths.data={tmp_path}/nothing",
        f"hydra.run.dir={out}", "progress=false", "tracking.mode=offline",
    ]
    env = {**os.environ, "WANDB_MODE": "offline"}
    done = subprocess.run(command, capture_output=True, text=True, cwd=tmp_path, env=env, timeout=900, check=False)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-3000:]
    row = json.loads((out / "episodes.jsonl").read_text().splitlines()[0])
    assert row["success"] and row["extra"]["video"] == f"videos/{TASK}/s0-e0000-PASS.mp4"
    assert _frames(out / row["extra"]["video"]) == row["extra"]["video_frames"] > 10
    table = (out / "table.md").read_text()
    assert f"\n\nRollout videos (videos/<task>/s<seed>-e<episode>-PASS|FAIL.mp4):\n- {TASK}: 1 (1 PASS, 0 FAIL): [s0-e0000-PASS](videos/{TASK}/s0-e0000-PASS.mp4)\n" in table
    report = subprocess.run([str(Path(sys.executable).parent / "xicm-report"), str(out)], capture_output=True, text=True, check=False)
    assert report.returncode == 0 and f"- {TASK}: 1 (1 PASS, 0 FAIL)" in report.stdout

    run = offline_run_record(out)
    assert run.run_group == "smoke"  # the experiment preset groups the sweep's runs
    # tags are the overrides that define the run: not video.* or progress (src/xicm/core/results/run_dir.OUTSIDE_IDENTITY)
    assert "policy=oracle" in run.tags and not {"video.enabled=true", "progress=false"} & set(run.tags)
    logged = list((out / "wandb").glob(f"offline-run-*/files/media/videos/videos/{TASK}_*.mp4"))
    assert len(logged) == 1
