"""(first frame, instruction) -> last frame pairs from a pool file, with a held-out split."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from xicm.core.results.dataset import DEMOS, _demo_ids, _open_read, _str, require_pool
from xicm.core.contracts.errors import ConfigError


@dataclass
class Pairs:
    demo_ids: list[str]
    tasks: list[str]
    instructions: list[str]
    episodes: np.ndarray  # (N,) int
    first: np.ndarray  # (N, H, W, 3) uint8
    last: np.ndarray  # (N, H, W, 3) uint8

    def __len__(self) -> int:
        return len(self.demo_ids)

    def subset(self, mask: np.ndarray) -> "Pairs":
        idx = np.flatnonzero(mask)
        return Pairs(
            [self.demo_ids[i] for i in idx],
            [self.tasks[i] for i in idx],
            [self.instructions[i] for i in idx],
            self.episodes[idx],
            self.first[idx],
            self.last[idx],
        )

    def fingerprint(self) -> str:
        """sha256 over demo ids, instructions and both frames: which data a model was trained on."""
        h = hashlib.sha256()
        for i, did in enumerate(self.demo_ids):
            h.update(did.encode() + b"\t" + self.instructions[i].encode() + b"\0")
        h.update(np.ascontiguousarray(self.first).tobytes())
        h.update(np.ascontiguousarray(self.last).tobytes())
        return h.hexdigest()


def load_pairs(path: str | Path, tasks: list[str] | None = None) -> Pairs:
    """Every demo of the pool (of `tasks` when given) that has both front frames, by demo id."""
    path = require_pool(path)
    wanted = None if tasks is None else set(tasks)
    ids, task_names, texts, episodes, firsts, lasts = [], [], [], [], [], []
    with _open_read(path) as f:
        for did in _demo_ids(f):
            g = f[f"{DEMOS}/{did}"]
            task = _str(g.attrs["task"])
            if (wanted is not None and task not in wanted) or "first_rgb" not in g or "last_rgb" not in g:
                continue
            ids.append(did)
            task_names.append(task)
            texts.append(_str(g.attrs["instruction"]))
            episodes.append(int(g.attrs["episode"]))
            firsts.append(g["first_rgb"][()])
            lasts.append(g["last_rgb"][()])
    if not ids:
        raise ConfigError(f"the pool {path} has no demos with first and last front frames" + (f" of {sorted(wanted)}" if wanted else ""))
    shapes = {a.shape for a in firsts + lasts}
    if len(shapes) != 1:
        raise ConfigError(f"the pool {path} mixes frame sizes {sorted(shapes)}; collect it with one image_size")
    return Pairs(ids, task_names, texts, np.asarray(episodes), np.stack(firsts), np.stack(lasts))


def split(pairs: Pairs, heldout_every: int) -> tuple[Pairs, Pairs]:
    """(train, held-out): a demo is held out when its episode number % heldout_every is
    heldout_every - 1, so every task keeps the same share of held-out demos."""
    if heldout_every < 2:
        return pairs, pairs.subset(np.zeros(len(pairs), bool))
    held = pairs.episodes % heldout_every == heldout_every - 1
    if held.all():
        raise ConfigError("every demo would be held out; raise train.heldout_every or collect more demos")
    return pairs.subset(~held), pairs.subset(held)
