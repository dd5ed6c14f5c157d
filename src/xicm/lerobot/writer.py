"""Write staged episodes as a LeRobot dataset with lerobot's own writer.

Runs inside the lerobot environment (env.py), not in xicm's: imports only the
standard library, numpy and lerobot. Usage: python writer.py MANIFEST.json

The manifest (written by xicm.lerobot.dataset_writer) names the dataset (repo_id, root, fps,
robot_type, features, use_videos, vcodec), which staged array fills each feature (`columns`),
and lists the staged episodes, each an .npz of arrays with T rows and the episode's task text
under "instruction"; `rows` (null: all) lists, per episode, the staged rows that become frames;
`episode_metadata` (null: none) gives, per episode, extra columns of meta/episodes/*.parquet
(where the episode came from: xicm/export/provenance.py), written by lerobot with its own columns.
"""

import json
import sys

import numpy as np
from lerobot.datasets.lerobot_dataset import LeRobotDataset


def main(manifest_path: str) -> None:
    with open(manifest_path) as f:
        manifest = json.load(f)
    features = {key: {**ft, "shape": tuple(ft["shape"])} for key, ft in manifest["features"].items()}
    dataset = LeRobotDataset.create(
        repo_id=manifest["repo_id"],
        fps=manifest["fps"],
        features=features,
        root=manifest["root"],
        robot_type=manifest["robot_type"],
        use_videos=manifest["use_videos"],
        vcodec=manifest["vcodec"],
        image_writer_threads=manifest["image_writer_threads"],
    )
    extra = manifest.get("episode_metadata")
    if extra is not None:
        _add_episode_columns(dataset.meta, extra)
    for n, path in enumerate(manifest["episodes"], start=1):
        with np.load(path) as staged:
            columns = {key: staged[manifest["columns"][key]] for key in features}
            task = str(staged["instruction"])
        rows = range(len(next(iter(columns.values())))) if manifest.get("rows") is None else manifest["rows"][n - 1]
        for t in rows:
            dataset.add_frame({**{key: column[t] for key, column in columns.items()}, "task": task})
        dataset.save_episode()
        print(f"writer.py: episode {n}/{len(manifest['episodes'])} ({len(rows)} frames)", flush=True)
    dataset.finalize()


def _add_episode_columns(meta, extra: list[dict]) -> None:
    """LeRobotDataset.save_episode hands each episode's row to meta.save_episode (its
    `episode_metadata`: where the episode's frames and videos lie); add the episode's own
    columns to that row, so lerobot's metadata writer stores them beside its columns."""
    save = meta.save_episode

    def save_with_columns(episode_index, episode_length, episode_tasks, episode_stats, episode_metadata):
        return save(episode_index, episode_length, episode_tasks, episode_stats,
                    {**episode_metadata, **extra[episode_index]})

    meta.save_episode = save_with_columns


if __name__ == "__main__":
    main(sys.argv[1])
