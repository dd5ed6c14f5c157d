"""The staging folder of an export: one .npz per recorded episode, written atomically, and one
JSON per attempt, so a killed export resumes where it stopped (core.collect_walk drives it).

    <staging>/settings.json                      what the episodes were recorded with
    <staging>/episodes/<task>/s<seed>/e<NNNN>.npz   arrays named after the dataset's features,
                                                    the instruction and the scene's variation
    <staging>/attempts/<task>/s<seed>/e<NNNN>.json  {"success", "error", "note"}
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from xicm.core.results.atomic import write_atomic, write_json_atomic
from xicm.core.results.dataset import Attempt, demo_id
from xicm.core.contracts.errors import ConfigError


@dataclass
class StagedEpisode:
    """One successful scripted demo, recorded at the control rate, ready for the dataset."""

    task: str
    seed: int
    episode: int
    instruction: str
    variation: int  # the task variation reset(task, seed, episode) drew (Simulator.variation())
    arrays: dict[str, np.ndarray]  # feature name -> (T, ...) array

    @property
    def demo_id(self) -> str:
        return demo_id(self.task, self.seed, self.episode)


class Staging:
    def __init__(self, root: str | Path, settings: dict):
        self.root = Path(root)
        self.settings = settings

    def __enter__(self) -> "Staging":
        path = self.root / "settings.json"
        if path.exists():
            old = json.loads(path.read_text())
            if old != self.settings:
                changed = sorted(k for k in set(old) | set(self.settings) if old.get(k) != self.settings.get(k))
                raise ConfigError(
                    f"the staging folder {self.root} holds episodes recorded with other settings ({', '.join(changed)}); "
                    "delete it, or choose another export.out_dir"
                )
        else:
            write_json_atomic(path, self.settings)
        return self

    def __exit__(self, *exc) -> None:
        pass

    def episode_path(self, did: str) -> Path:
        return self.root / "episodes" / f"{did}.npz"

    def has(self, did: str) -> bool:
        return self.episode_path(did).exists()

    def write(self, staged: StagedEpisode) -> None:
        buffer = io.BytesIO()
        np.savez_compressed(buffer, instruction=np.array(staged.instruction), variation=np.array(staged.variation),
                            **staged.arrays)
        write_atomic(self.episode_path(staged.demo_id), buffer.getvalue())

    def log_attempt(self, task: str, seed: int, episode: int, success: bool, note: str = "", error: bool = False) -> None:
        row = {"success": bool(success), "error": bool(error), "note": str(note)}
        write_json_atomic(self.root / "attempts" / f"{demo_id(task, seed, episode)}.json", row)

    def attempts(self) -> dict[tuple[str, int, int], Attempt]:
        out = {}
        for path in (self.root / "attempts").glob("*/s*/e*.json"):
            task, seed, episode = _scene_of(path)
            row = json.loads(path.read_text())
            out[(task, seed, episode)] = Attempt(row["success"], row["error"], row["note"])
        return out

    def episodes(self, task: str, seed: int, limit: int) -> list[Path]:
        """The first `limit` staged episodes of a task, in episode order (what a sequential run kept)."""
        found = sorted((self.root / "episodes" / task / f"s{int(seed)}").glob("e*.npz"))
        return found[:limit]


def staged_scene(path: Path) -> tuple[str, int, int, int]:
    """(task, seed, episode, variation) of a staged episode file."""
    with np.load(path) as staged:
        variation = int(staged["variation"])
    return (*_scene_of(path), variation)


def _scene_of(path: Path) -> tuple[str, int, int]:
    """(task, seed, episode) from a staged file's path: <task>/s<seed>/e<NNNN>.<ext>."""
    return path.parent.parent.name, int(path.parent.name[1:]), int(path.stem[1:])
