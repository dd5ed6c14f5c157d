"""Retriever "similarity": cosine top-k between the query's feature and the pool's features.

Features come from the configured encoder: the query's is
`encoder.encode([(query.front_rgb, query.instruction)])`, the pool's are
`encoder.encode([(demo.first_rgb, demo.instruction), ...])`, computed once in `prepare(pool)`
and cached on disk as an .npy file keyed by `encoder.cache_key()` and a hash of the pool's
demo ids and instructions (and first frames when the encoder's `uses_images` is true), written
atomically (a temporary file, then a rename).
Scores are cosine similarities (`score: cosine`), or raw dot products of the features as the
encoder gives them (`score: dot`, X-ICM's ranking); equal scores (to 1e-6) are ordered by demo
id, so the ranking is deterministic.

Options:
    cache_dir: folder of the feature cache; default $XICM_CACHE/features, or
        ~/.cache/xicm/features when XICM_CACHE is not set.
    exclude_same_task: leave out demos of the query's own task (leave-one-task-out
        studies), default False.
    score: cosine | dot (default cosine).
"""

from __future__ import annotations

import hashlib
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

from xicm.core.results.atomic import write_atomic
from xicm.core.contracts.errors import ConfigError
from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.interfaces import Encoder, Retriever
from xicm.core.contracts.schema import one_of
from xicm.core.contracts.types import Demo, Query
from xicm.plugins.retrievers.random import candidates

TIE_DECIMALS = 6  # scores equal to this many decimals count as ties (broken by demo id)
SCORES = ("cosine", "dot")


def default_cache_dir() -> Path:
    root = os.environ.get("XICM_CACHE")
    base = Path(root).expanduser() if root else Path.home() / ".cache" / "xicm"
    return base / "features"


def pool_fingerprint(encoder_key: str, pool: list[Demo], with_images: bool = False) -> str:
    """sha256 over the encoder's cache key and every demo's id and instruction, in pool order
    (and its first frame, for encoders whose features depend on the image)."""
    h = hashlib.sha256()
    h.update(encoder_key.encode())
    for d in pool:
        h.update(b"\0" + d.demo_id.encode() + b"\t" + d.instruction.encode())
        if with_images and d.first_rgb is not None:
            h.update(np.ascontiguousarray(d.first_rgb).tobytes())
    return h.hexdigest()


def normalise_rows(x: np.ndarray) -> np.ndarray:
    """Rows flattened and L2-normalised (float32), so a dot product is the cosine."""
    x = np.asarray(x, dtype=np.float32)
    if x.ndim == 1:
        x = x[None]
    x = x.reshape(len(x), -1)  # e.g. latent images flattened
    norm = np.linalg.norm(x, axis=1, keepdims=True)
    return x / np.maximum(norm, 1e-12)


@dataclass
class SimilarityOptions:
    cache_dir: Optional[str] = None  # None: $XICM_CACHE/features
    exclude_same_task: bool = False
    score: str = field(default="cosine", metadata=one_of(*SCORES))


class SimilarityRetriever(Retriever):
    def __init__(self, options: SimilarityOptions | None = None, encoder: Encoder | None = None):
        if encoder is None:
            raise ConfigError("the similarity retriever needs an encoder; set `encoder=` (e.g. encoder=minilm)")
        o = options if options is not None else SimilarityOptions()
        self.encoder = encoder
        self.cache_dir = Path(o.cache_dir).expanduser() if o.cache_dir else default_cache_dir()
        self.exclude_same_task = o.exclude_same_task
        self.score = o.score
        self._rows: dict[str, int] = {}
        self._features = np.zeros((0, 0), np.float32)
        self.cache_path: Path | None = None
        self.cache_hit: bool | None = None

    def features_key(self) -> str:
        return self.encoder.cache_key() + ("" if self.score == "cosine" else f":{self.score}")

    def prepare(self, pool: list[Demo]) -> None:
        if not pool:
            raise ValueError("the demonstration pool is empty; collect demonstrations first (xicm-collect)")
        key = self.features_key()
        slug = re.sub(r"[^A-Za-z0-9._-]+", "_", key)[:60]
        fingerprint = pool_fingerprint(key, pool, with_images=getattr(self.encoder, "uses_images", False))
        path = self.cache_dir / f"{slug}-{fingerprint[:24]}.npy"
        feats = None
        if path.exists():
            try:
                feats = np.load(path)
            except (OSError, ValueError):
                feats = None  # unreadable cache: recompute and overwrite
            if feats is not None and (feats.ndim != 2 or len(feats) != len(pool)):
                feats = None
        self.cache_hit = feats is not None
        if feats is None:
            feats = self._rows_of(self.encoder.encode([(d.first_rgb, d.instruction) for d in pool]))
            if len(feats) != len(pool):
                raise RuntimeError(f"encoder returned {len(feats)} features for {len(pool)} demos")
            write_atomic(path, lambda f: np.save(f, feats))
        self.cache_path = path
        self._features = np.asarray(feats, np.float32)
        self._rows = {d.demo_id: i for i, d in enumerate(pool)}

    def _rows_of(self, features: np.ndarray) -> np.ndarray:
        """Features as scored: unit rows for cosine, as encoded (flattened, float32) for dot."""
        if self.score == "cosine":
            return normalise_rows(features)
        x = np.asarray(features, dtype=np.float32)
        return x.reshape(len(x), -1) if x.ndim > 1 else x[None]

    def scores(self, query: Query, demos: list[Demo]) -> np.ndarray:
        """Cosine similarity (or dot product) of the query to each demo (demos must have been prepared)."""
        q = self._rows_of(self.encoder.encode([(query.front_rgb, query.instruction)]))[0]
        rows = np.fromiter((self._rows[d.demo_id] for d in demos), dtype=np.int64, count=len(demos))
        return self._features[rows] @ q

    def select(self, query: Query, pool: list[Demo], k: int, rng: np.random.Generator) -> list[tuple[Demo, float]]:
        demos = candidates(query, pool, self.exclude_same_task)
        if any(d.demo_id not in self._rows for d in pool):
            self.prepare(pool)  # not prepared yet, or a different pool
        s = self.scores(query, demos)
        k = max(0, min(int(k), len(demos)))
        if k == 0:
            return []
        neg = -np.round(s.astype(np.float64), TIE_DECIMALS)
        # everything that scores at least the k-th best (ties included), then an exact sort
        kth = np.partition(neg, k - 1)[k - 1]
        cand = np.flatnonzero(neg <= kth)
        order = sorted(cand.tolist(), key=lambda i: (neg[i], demos[i].demo_id))[:k]
        return [(demos[i], float(s[i])) for i in order]


@hookimpl
def register_retrievers(register):
    register("similarity", SimilarityRetriever, options=SimilarityOptions)
