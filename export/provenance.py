"""Where each exported episode came from, as columns of LeRobot's per-episode metadata
(meta/episodes/*.parquet), so any training episode can be reset in the Gymnasium env and replayed.

LeRobot v3 keeps one row per episode there and names its own columns by source ("data/...",
"videos/<key>/...", "stats/..."); LeRobotDataset reads every column but "stats/*" into
`dataset.meta.episodes`. xicm's columns take the prefix "scene/":

    scene/task               str   the xicm task name (the Gymnasium id is xicm/<Task>-v0)
    scene/seed, scene/episode int  reset(task, seed, episode) rebuilds the scene
    scene/variation          int   the task variation that reset drew (Simulator.variation())
    scene/simulator          str   the simulator plugin's name
    scene/simulator_options  str   JSON: the simulator options the export ran with (its
                                   defaults filled in, `control_mode` the `action` column's)
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

PREFIX = "scene/"


@dataclass(frozen=True)
class Provenance:
    task: str
    seed: int
    episode: int
    variation: int
    simulator: str
    simulator_options: dict[str, Any]

    def columns(self) -> dict[str, Any]:
        """The episode's row of meta/episodes (JSON-safe scalars)."""
        return {
            f"{PREFIX}task": self.task,
            f"{PREFIX}seed": int(self.seed),
            f"{PREFIX}episode": int(self.episode),
            f"{PREFIX}variation": int(self.variation),
            f"{PREFIX}simulator": self.simulator,
            f"{PREFIX}simulator_options": json.dumps(self.simulator_options, sort_keys=True),
        }

    @classmethod
    def from_row(cls, row: dict[str, Any]) -> "Provenance":
        """From one episode's metadata as LeRobot reads it (`dataset.meta.episodes[i]`)."""
        missing = [k for k in cls.column_names() if k not in row]
        if missing:
            raise ValueError(f"the episode metadata has no {', '.join(missing)}: not an xicm export, or one "
                             "written before the scene was recorded")
        return cls(
            task=str(row[f"{PREFIX}task"]),
            seed=int(row[f"{PREFIX}seed"]),
            episode=int(row[f"{PREFIX}episode"]),
            variation=int(row[f"{PREFIX}variation"]),
            simulator=str(row[f"{PREFIX}simulator"]),
            simulator_options=json.loads(row[f"{PREFIX}simulator_options"]),
        )

    @staticmethod
    def column_names() -> list[str]:
        return [f"{PREFIX}{name}" for name in ("task", "seed", "episode", "variation", "simulator", "simulator_options")]

    def env_kwargs(self, obs_mode: str = "rgb") -> dict[str, Any]:
        """gymnasium.make(env_id(task), **these) builds the simulator the episode was recorded in
        (XicmEnv's own arguments taken out of the options; `render` follows obs_mode)."""
        options = dict(self.simulator_options)
        options.pop("render", None)
        kwargs: dict[str, Any] = {"obs_mode": obs_mode, "simulator": self.simulator}
        for key in ("control_mode", "cameras", "image_size"):
            if key in options:
                kwargs[key] = options.pop(key)
        kwargs["variations"] = "sampled" if options.pop("sample_variations", True) else "zero"
        kwargs["simulator_options"] = options
        return kwargs

    def reset_kwargs(self) -> dict[str, Any]:
        """env.reset(**these) loads the episode's scene."""
        return {"seed": self.seed, "options": {"episode": self.episode}}


def from_dump(loaded: dict) -> list[Provenance]:
    """Each episode's provenance, in episode order, from what dataset_writer.read_dataset dumped
    (lerobot_reader.py: the `episodes` JSON of LeRobot's own metadata reader)."""
    return [Provenance.from_row(row) for row in json.loads(str(loaded["episodes"]))]
