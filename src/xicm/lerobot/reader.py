"""Load a LeRobot dataset with lerobot's own LeRobotDataset and dump what a check needs.

Runs inside the lerobot environment (env.py): imports only the standard library,
numpy and lerobot. Usage: python reader.py ROOT REPO_ID OUT.npz

OUT.npz holds: num_frames, num_episodes, features (JSON text), tasks (each episode's task
text), episodes (JSON text: each episode's row of meta/episodes as lerobot reads it, its
"stats/*" left out; an xicm export's "scene/*" columns among them, xicm/export/provenance.py),
episode_index (per frame), every non-image column of the dataset (per frame, keyed
by feature name), and for each camera the decoded first and last frame of every episode
(images.<camera>: (episodes, 2, H, W, 3) uint8).
"""

import json
import sys

import numpy as np
from lerobot.datasets.lerobot_dataset import LeRobotDataset


def main(root: str, repo_id: str, out: str) -> None:
    dataset = LeRobotDataset(repo_id, root=root, video_backend="torchcodec")
    table = dataset.hf_dataset.with_format("numpy")
    columns = {key: np.stack(table[key]) for key, ft in dataset.features.items() if ft["dtype"] not in ("image", "video")}
    episode_index = columns["episode_index"].reshape(-1)
    task_of = {int(i): dataset.meta.tasks.index[i] for i in range(len(dataset.meta.tasks))}
    tasks, images = [], {key: [] for key in dataset.meta.camera_keys}
    for episode in range(dataset.num_episodes):
        rows = np.nonzero(episode_index == episode)[0]
        tasks.append(task_of[int(columns["task_index"].reshape(-1)[rows[0]])])
        first, last = dataset[int(rows[0])], dataset[int(rows[-1])]
        for key in images:  # decoded from the video: (C, H, W) float in [0, 1]
            pair = [np.round(item[key].numpy().transpose(1, 2, 0) * 255).astype(np.uint8) for item in (first, last)]
            images[key].append(np.stack(pair))
    np.savez(
        out,
        num_frames=dataset.num_frames,
        num_episodes=dataset.num_episodes,
        features=json.dumps({k: {**v, "shape": list(v["shape"])} for k, v in dataset.features.items()}),
        tasks=np.array(tasks),
        episodes=json.dumps(dataset.meta.episodes.to_list()),
        **{f"column.{key}": value for key, value in columns.items()},
        **{f"images.{key.removeprefix('observation.images.')}": np.stack(v) for key, v in images.items()},
    )


if __name__ == "__main__":
    main(*sys.argv[1:])
