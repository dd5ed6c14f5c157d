"""Staged episodes -> the LeRobot dataset at `out_dir`, written by lerobot itself (writer.py
in the lerobot environment) into a temp folder beside, then renamed into place."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from xicm.core.results.atomic import write_dir_atomic, write_json_atomic
from xicm.core.contracts.spaces import ControlSpec
from xicm.export import features as feats
from xicm.lerobot.env import check_ffmpeg, env_python, run_script

ROBOT_TYPE = "franka_panda"


def write_dataset(
    out_dir: Path,
    episodes: list[Path],
    *,
    repo_id: str,
    fps: int,
    sizes: dict[str, tuple[int, int]],
    spec: ControlSpec,
    use_videos: bool,
    frames: str = "control",
    vcodec: str,
    cache: str | Path,
    episode_metadata: list[dict] | None = None,
    log=print,
) -> None:
    """`episode_metadata`: per episode, extra columns of meta/episodes (xicm.export.provenance)."""
    if episode_metadata is not None and len(episode_metadata) != len(episodes):
        raise ValueError(f"{len(episode_metadata)} rows of episode metadata for {len(episodes)} episodes")
    python = env_python(cache, log)
    features = feats.features(sizes, spec, use_videos, frames)
    rows = None  # every staged row is a frame; key frames keep each key action's first step
    if frames == "key":
        rows = []
        for path in episodes:
            with np.load(path) as staged:
                rows.append(feats.key_frame_rows(staged["key_action.index"].reshape(-1)))
    manifest_path = out_dir.with_name(f".{out_dir.name}.manifest.json")

    def write(tmp: Path) -> None:
        tmp.rmdir()  # LeRobotDataset.create makes its root itself (and refuses an existing one)
        manifest = {
            "repo_id": repo_id,
            "root": str(tmp),
            "fps": int(fps),
            "robot_type": ROBOT_TYPE,
            "features": features,
            "columns": {key: feats.staged_column(key, spec.control_mode, frames) for key in features},
            "use_videos": bool(use_videos),
            "vcodec": vcodec,
            "image_writer_threads": min(4, os.cpu_count() or 1),
            "episodes": [str(p) for p in episodes],
            "rows": rows,
            "episode_metadata": episode_metadata,
        }
        write_json_atomic(manifest_path, manifest)
        run_script(python, "writer.py", str(manifest_path))

    try:
        write_dir_atomic(out_dir, write)
    finally:
        manifest_path.unlink(missing_ok=True)


def read_dataset(root: Path, repo_id: str, out_npz: Path, cache: str | Path, log=print) -> None:
    """Load the dataset with lerobot's own LeRobotDataset (reader.py) and dump it to `out_npz`."""
    check_ffmpeg()
    run_script(env_python(cache, log), "reader.py", str(root), repo_id, str(out_npz))


def dataset_size(root: Path) -> int:
    return sum(p.stat().st_size for p in Path(root).rglob("*") if p.is_file())


