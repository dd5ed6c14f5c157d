"""Detector "noisy_oracle": the oracle detector with seeded perception errors, for studying how
much X-ICM's success depends on perception (a sensitivity study the paper did not run).

Errors, applied to the oracle's result in this order:
    - drop: each found object is left out with probability `drop_prob` (the prompt then says
      "<name> not detected");
    - swap: with probability `swap_prob` two found objects exchange their positions (the
      names are attached to the wrong objects);
    - noise: every remaining position gets Gaussian noise of `noise_cm` centimetres per axis.

The random draws depend on `seed` and on the scene (the oracle's positions rounded to 1 mm),
so the same episode gets the same errors in any process and on every re-query of an episode
whose objects did not move.

Options: noise_cm (0), drop_prob (0), swap_prob (0), seed (0), plus the oracle's
cameras and min_pixels.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass, field

import numpy as np

from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.schema import at_least, between
from xicm.core.contracts.types import Observation

from .oracle import OracleDetector, OracleOptions


@dataclass
class NoisyOracleOptions(OracleOptions):
    noise_cm: float = field(default=0.0, metadata=at_least(0))
    drop_prob: float = field(default=0.0, metadata=between(0, 1))
    swap_prob: float = field(default=0.0, metadata=between(0, 1))
    seed: int = field(default=0, metadata=at_least(0))  # numpy seeds are non-negative


class NoisyOracleDetector(OracleDetector):
    def __init__(self, options: NoisyOracleOptions | None = None):
        o = options if options is not None else NoisyOracleOptions()
        super().__init__(o)
        self.noise_m = o.noise_cm / 100.0
        self.drop_prob, self.swap_prob = o.drop_prob, o.swap_prob
        self.seed = o.seed

    def detect(self, obs: Observation, names: list[str]) -> dict[str, tuple[float, float, float]]:
        truth = super().detect(obs, names)
        rng = np.random.default_rng([self.seed, scene_key(truth)])
        kept = [n for n in truth if rng.random() >= self.drop_prob]
        positions = {n: np.asarray(truth[n], dtype=float) for n in kept}
        if len(kept) >= 2 and rng.random() < self.swap_prob:
            a, b = rng.choice(len(kept), size=2, replace=False)
            positions[kept[a]], positions[kept[b]] = positions[kept[b]], positions[kept[a]]
        result = {}
        for name in kept:
            p = positions[name] + rng.normal(0.0, self.noise_m, size=3)
            result[name] = (float(p[0]), float(p[1]), float(p[2]))
        return result


def scene_key(objects: dict[str, tuple[float, float, float]]) -> int:
    """A 32-bit key of the names and mm-rounded positions (stable across processes)."""
    text = ";".join(f"{n}:{np.round(np.asarray(p) * 1000).astype(int).tolist()}" for n, p in sorted(objects.items()))
    return zlib.crc32(text.encode())


@hookimpl
def register_detectors(register):
    register("noisy_oracle", NoisyOracleDetector, options=NoisyOracleOptions)
