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
import numbers
from dataclasses import dataclass
from typing import Any

PREFIX = "scene/"
#: the columns after the prefix, with the type each holds (simulator_options: JSON text of an object)
FIELDS = (("task", str), ("seed", int), ("episode", int), ("variation", int), ("simulator", str), ("simulator_options", dict))
_KIND_WORDS = {str: "a string", int: "an integer", dict: "a JSON object"}


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
        row = {f"{PREFIX}{name}": kind(getattr(self, name)) for name, kind in FIELDS if kind is not dict}
        return {**row, f"{PREFIX}simulator_options": json.dumps(self.simulator_options, sort_keys=True)}

    @classmethod
    def from_row(cls, row: dict[str, Any]) -> "Provenance":
        """From one episode's metadata as LeRobot reads it (`dataset.meta.episodes[i]`)."""
        missing = [k for k in column_names() if k not in row]
        if missing:
            raise ValueError(f"the episode metadata has no {', '.join(missing)}: not an xicm export, or one "
                             "written before the scene was recorded")
        values: dict[str, Any] = {}
        for name, kind in FIELDS:
            value = row[f"{PREFIX}{name}"]
            if kind is dict and isinstance(value, str):
                try:
                    value = json.loads(value)
                except ValueError:
                    pass  # named below
            expected = numbers.Integral if kind is int else kind  # numpy's integers too
            if not isinstance(value, expected) or isinstance(value, bool):
                raise ValueError(f"the episode metadata's {PREFIX}{name} must be {_KIND_WORDS[kind]}, "
                                 f"not {str(value)[:80]!r}")
            values[name] = kind(value)
        return cls(**values)

    def env_kwargs(self, obs_mode: str = "rgb") -> dict[str, Any]:
        """gymnasium.make(env_id(task), **these) builds the simulator the episode was recorded in
        (XicmEnv's own arguments taken out of the options; `render` follows obs_mode)."""
        options = dict(self.simulator_options)
        options.pop("render", None)
        kwargs: dict[str, Any] = {"obs_mode": obs_mode, "simulator": self.simulator}
        for key in ("control_mode", "cameras", "image_size"):
            if key in options:
                kwargs[key] = options.pop(key)
        # the Simulator's sample_variations (src/xicm/core/contracts/interfaces.py): XicmEnv sets it from `variations`
        kwargs["variations"] = "sampled" if options.pop("sample_variations", True) else "zero"
        kwargs["simulator_options"] = options
        return kwargs

    def reset_kwargs(self) -> dict[str, Any]:
        """env.reset(**these) loads the episode's scene."""
        return {"seed": self.seed, "options": {"episode": self.episode}}


def column_names() -> list[str]:
    return [f"{PREFIX}{name}" for name, _ in FIELDS]


def from_dump(loaded: dict) -> list[Provenance]:
    """Each episode's provenance, in episode order, from what xicm.lerobot.dataset_writer.read_dataset dumped
    (xicm/lerobot/reader.py: the `episodes` JSON of LeRobot's own metadata reader)."""
    return [Provenance.from_row(row) for row in json.loads(str(loaded["episodes"]))]
