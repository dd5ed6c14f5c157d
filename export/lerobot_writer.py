"""Write staged episodes as a LeRobot dataset with lerobot's own writer.

Runs inside the lerobot environment (lerobot_env.py), not in xicm's: imports only the
standard library, numpy and lerobot. Usage: python lerobot_writer.py MANIFEST.json

The manifest (written by xicm.export.dataset_writer) names the dataset (repo_id, root, fps,
robot_type, features, use_videos, vcodec), which staged array fills each feature (`columns`),
and lists the staged episodes, each an .npz of arrays with T rows and the episode's task text
under "instruction"; `rows` (null: all) lists, per episode, the staged rows that become frames.
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
    for n, path in enumerate(manifest["episodes"], start=1):
        with np.load(path) as staged:
            columns = {key: staged[manifest["columns"][key]] for key in features}
            task = str(staged["instruction"])
        rows = range(len(next(iter(columns.values())))) if manifest.get("rows") is None else manifest["rows"][n - 1]
        for t in rows:
            dataset.add_frame({**{key: column[t] for key, column in columns.items()}, "task": task})
        dataset.save_episode()
        print(f"lerobot_writer: episode {n}/{len(manifest['episodes'])} ({len(rows)} frames)", flush=True)
    dataset.finalize()


if __name__ == "__main__":
    main(sys.argv[1])
