"""Encoder "dynamics": what a trained dynamics model expects the scene to become, plus the text.

A feature joins two L2-normalised parts, weighted so that the cosine similarity of two
features is `(1 - text_weight) * visual cosine + text_weight * text cosine`:

- visual, `mode: predicted_frame` (the paper's): the last frame the model samples from the
  first frame and the instruction (deterministic DDIM, `steps` steps, fixed starting noise
  `seed`), minus the first frame (`visual: change`, the default: the static scene does not
  count) or as it is (`visual: final`), flattened.
- visual, `mode: unet_features` (one forward pass): the UNet's mid-block and first up-block
  activations from pure noise at the last training timestep, pooled to 2×2.
- text: the checkpoint's text encoder's feature of the instruction (all-MiniLM by default; a
  mean over real tokens for transformers encoders, so it really depends on the text).

With `normalise: false` (X-ICM's feature, src/xicm/conf/encoder/dynamics_xicm.yaml) the visual part is
returned as predicted, not L2-normalised, and there is no text part (`text_weight` must be 0):
X-ICM ranks by the raw dot product of predicted final latents (its text term is constant, see
docs/AGNOSTOS.md), which the similarity retriever's `score: dot` computes.

Options:
    checkpoint: a folder written by xicm-train-dynamics (its `final/`, or the training
        out_dir, whose `final/` is then used, or any `checkpoints/step-N/`).
    mode: predicted_frame | unet_features (default predicted_frame).
    visual: change | final (default change; predicted_frame mode only).
    steps: DDIM sampling steps (default 1, the model's direct estimate; the paper samples 50).
    seed: starting noise (default 0).
    text_weight: 0..1 (default 0.5).
    batch_size: frames per forward pass (default 64).
    device: torch device (default cpu).
    normalise: L2-normalise and weight the parts (default true); false: the raw visual part alone.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from omegaconf import MISSING

from xicm.core.contracts.errors import ConfigError
from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.interfaces import Encoder
from xicm.core.contracts.schema import at_least, between, one_of

MODES = ("predicted_frame", "unet_features")
VISUALS = ("final", "change")


@dataclass
class DynamicsEncoderOptions:
    checkpoint: str = MISSING
    mode: str = field(default="predicted_frame", metadata=one_of(*MODES))
    visual: str = field(default="change", metadata=one_of(*VISUALS))
    steps: int = field(default=1, metadata=at_least(1))
    seed: int = 0
    text_weight: float = field(default=0.5, metadata=between(0, 1))
    batch_size: int = field(default=64, metadata=at_least(1))
    device: str = "cpu"
    normalise: bool = True
_models: dict[tuple[str, str], object] = {}
_lock = threading.Lock()


def resolve_checkpoint(path: str | Path) -> Path:
    """The checkpoint folder itself, or <path>/final; ConfigError naming what to do otherwise."""
    folder = Path(str(path)).expanduser()
    for candidate in (folder, folder / "final"):
        if (candidate / "dynamics.json").exists() and (candidate / "unet").is_dir():
            return candidate
    steps = sorted((folder / "checkpoints").glob("step-*")) if (folder / "checkpoints").is_dir() else []
    hint = f"; training has not finished: use encoder.checkpoint={steps[-1]} or re-run xicm-train-dynamics" if steps else ""
    raise ConfigError(
        f"no trained dynamics model at {folder}{hint or '; train one with xicm-train-dynamics (e.g. xicm-train-dynamics pool=seen)'}"
    )


def _load(folder: Path, device: str):
    from xicm.plugins.dynamics.model import load_unet

    with _lock:
        key = (str(folder.resolve()), device)
        if key not in _models:
            _models[key] = load_unet(folder, device)
        return _models[key]


class DynamicsEncoder(Encoder):
    uses_images = True

    def __init__(self, options: DynamicsEncoderOptions):
        from xicm.plugins.dynamics.model import checkpoint_hash, read_meta

        o = options
        if not o.normalise and o.text_weight != 0:
            raise ConfigError(
                f"encoder.normalise=false returns the raw visual feature alone, so encoder.text_weight must be 0 (got {o.text_weight:g})"
            )

        self.folder = resolve_checkpoint(o.checkpoint)
        self.meta = read_meta(self.folder)
        self.mode, self.visual = o.mode, o.visual
        self.steps, self.seed = o.steps, o.seed
        self.text_weight = float(o.text_weight)
        self.batch_size, self.device = o.batch_size, o.device
        self.normalise = o.normalise
        self._hash = checkpoint_hash(self.folder)
        self._scheduler = _scheduler_config(self.folder)  # read once: queries come one per episode

    def cache_key(self) -> str:
        from xicm.plugins.dynamics.model import SAMPLER

        how = f"{self.mode}-{self.visual}-s{self.steps}-{SAMPLER}" if self.mode == "predicted_frame" else self.mode
        scale = f"tw{self.text_weight:g}" if self.normalise else "raw"
        return f"dynamics:{how}:seed{self.seed}:{scale}:{self._hash[:16]}"

    def encode(self, items: list[tuple[np.ndarray | None, str]]) -> np.ndarray:
        if any(rgb is None for rgb, _ in items):
            raise ConfigError("the dynamics encoder needs front-camera frames; the pool or query has none")
        if not items:
            return np.zeros((0, 0), np.float32)
        from xicm.plugins.dynamics.text import embed_unique, text_encoder
        from xicm.plugins.retrievers.similarity import normalise_rows

        # one text pass gives both the UNet's context and the text feature
        context, text = embed_unique(text_encoder(self.meta.get("text_encoder"), self.device), [str(t) for _, t in items])
        visual = self._visual([rgb for rgb, _ in items], context)
        if not self.normalise:
            return visual.reshape(len(visual), -1).astype(np.float32)
        return np.concatenate(
            [normalise_rows(visual) * np.sqrt(1.0 - self.text_weight), normalise_rows(text) * np.sqrt(self.text_weight)], axis=1
        ).astype(np.float32)

    def _visual(self, frames: list[np.ndarray], context) -> np.ndarray:
        """The visual part for frames, with `context` (N, tokens, dim) their instructions' embeddings."""
        import torch

        from xicm.plugins.dynamics import model as dm
        from xicm.plugins.dynamics.images import to_model

        unet = _load(self.folder, self.device)
        res = int(self.meta["resolution"])
        out = []
        starts = range(0, len(frames), self.batch_size)
        if len(starts) > 1:  # a pool: show progress on a terminal (tqdm stays quiet otherwise)
            from tqdm import tqdm

            starts = tqdm(starts, desc=f"dynamics features ({len(frames)} frames)", unit="batch", disable=None)
        for i in starts:
            first = to_model(frames[i : i + self.batch_size], res)
            ctx = context[i : i + self.batch_size]
            if self.mode == "unet_features":
                timestep = int(self.meta["num_train_timesteps"]) - 1
                feat = dm.pooled_activations(unet, first, ctx, timestep, seed=self.seed)
            else:
                last = dm.predict_last(unet, self._scheduler, self.meta, first, ctx, self.steps, self.seed)
                feat = (last - first if self.visual == "change" else last).flatten(1)
            out.append(feat.to(torch.float32).numpy())
        return np.concatenate(out)


def _scheduler_config(folder: Path) -> dict:
    import json

    return json.loads((folder / "scheduler" / "scheduler_config.json").read_text(encoding="utf-8"))


@hookimpl
def register_encoders(register):
    register("dynamics", DynamicsEncoder, options=DynamicsEncoderOptions)
