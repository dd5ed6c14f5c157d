"""Every random draw comes from a generator seeded by (seed, task, episode)."""

from __future__ import annotations

import zlib

import numpy as np


def episode_rng(seed: int, task: str, episode: int, stream: str = "scene") -> np.random.Generator:
    """Independent generator per (seed, task, episode, stream); identical in any process."""
    entropy = [int(seed) & 0xFFFFFFFF, zlib.crc32(task.encode()), int(episode), zlib.crc32(stream.encode())]
    return np.random.default_rng(np.random.SeedSequence(entropy))
