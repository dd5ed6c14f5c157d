"""The dynamics UNet: build, save, load, sample a predicted last frame, one-pass features.

InstructPix2Pix style: the UNet sees the noisy target concatenated with the clean first frame
(6 input channels, pixel space at `resolution`), the instruction embedding as cross-attention
context, and predicts the velocity (`prediction: v_prediction`, default), the added noise
(`epsilon`) or the clean target (`sample`). The target is the last frame (`target: frame`) or, by
default, the last minus the first frame scaled to unit variance (`target: residual`). A checkpoint folder holds
`unet/` and `scheduler/` in diffusers' save_pretrained format plus `dynamics.json` (resolution,
text encoder, training step, dataset fingerprint).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import torch
import torch.nn.functional as F

from xicm.core.contracts.errors import ConfigError
from xicm.plugins.dynamics.config_schema import PREDICTIONS

META_FILE = "dynamics.json"


def build_unet(model: dict[str, Any], text_dim: int):
    """A fresh UNet2DConditionModel from the `dynamics_model` config."""
    from diffusers import UNet2DConditionModel

    channels = tuple(int(c) for c in model["block_out_channels"])
    attention = [bool(a) for a in model.get("cross_attention", [i > 0 for i in range(len(channels))])]
    if len(attention) != len(channels):
        raise ConfigError("dynamics_model.cross_attention needs one entry per block_out_channels entry")
    down = tuple("CrossAttnDownBlock2D" if a else "DownBlock2D" for a in attention)
    up = tuple("CrossAttnUpBlock2D" if a else "UpBlock2D" for a in reversed(attention))
    return UNet2DConditionModel(
        sample_size=int(model["resolution"]),
        in_channels=6,
        out_channels=3,
        layers_per_block=int(model["layers_per_block"]),
        block_out_channels=channels,
        down_block_types=down,
        up_block_types=up,
        cross_attention_dim=int(text_dim),
        attention_head_dim=int(model["attention_head_dim"]),
        norm_num_groups=int(model["norm_num_groups"]),
    )


def train_scheduler(meta: dict[str, Any]):
    from diffusers import DDPMScheduler

    return DDPMScheduler(
        num_train_timesteps=int(meta["num_train_timesteps"]),
        beta_schedule="squaredcos_cap_v2",
        prediction_type=prediction_type(meta),
        **sample_clip(meta),
    )


def prediction_type(meta: dict[str, Any]) -> str:
    """What the UNet outputs: the added noise (epsilon), the velocity (v_prediction) or the clean
    target itself (sample). Checkpoints from before this option predicted the noise."""
    kind = str(meta["model"].get("prediction", "epsilon"))
    if kind not in PREDICTIONS:
        raise ConfigError(f"dynamics_model.prediction must be one of {', '.join(PREDICTIONS)}, got '{kind}'")
    return kind


def loss_target(scheduler, clean: torch.Tensor, noise: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
    """What the UNet's output is compared with in the training loss, per the scheduler's prediction type."""
    kind = scheduler.config.prediction_type
    if kind == "epsilon":
        return noise
    if kind == "v_prediction":
        return scheduler.get_velocity(clean, noise, t)
    return clean


def save_checkpoint(folder: Path, unet, scheduler, meta: dict[str, Any]) -> None:
    """Write unet/, scheduler/ and dynamics.json into folder (created)."""
    folder.mkdir(parents=True, exist_ok=True)
    unet.save_pretrained(folder / "unet")
    scheduler.save_pretrained(folder / "scheduler")
    (folder / META_FILE).write_text(json.dumps(meta, indent=2, sort_keys=True), encoding="utf-8")


def read_meta(folder: Path) -> dict[str, Any]:
    path = Path(folder) / META_FILE
    if not path.exists():
        raise ConfigError(f"{folder} is not a dynamics checkpoint (no {META_FILE}); train one with xicm-train-dynamics")
    return json.loads(path.read_text(encoding="utf-8"))


def load_unet(folder: Path, device: str = "cpu"):
    from diffusers import UNet2DConditionModel

    return UNet2DConditionModel.from_pretrained(Path(folder) / "unet").to(device).eval()


def checkpoint_hash(folder: Path) -> str:
    """sha256 over the checkpoint's weight and config files: changes whenever the model does."""
    h = hashlib.sha256()
    for path in sorted((Path(folder) / "unet").iterdir()):
        if path.is_file():
            h.update(path.name.encode() + b"\0")
            with open(path, "rb") as f:
                for block in iter(lambda: f.read(1 << 20), b""):
                    h.update(block)
    return h.hexdigest()


def _item_noise(n: int, shape: tuple[int, ...], seed: int) -> torch.Tensor:
    """The same starting noise for every item: features do not depend on batch composition."""
    g = torch.Generator().manual_seed(int(seed))
    return torch.randn((1, *shape), generator=g).expand(n, *shape).contiguous()


def encode_target(first: torch.Tensor, last: torch.Tensor, meta: dict[str, Any]) -> torch.Tensor:
    """What the diffusion model generates: the last frame, or (default) the change from the first
    frame scaled to unit variance (most pixels do not move, so the change is the hard part)."""
    if meta["target"] == "frame":
        return last
    return (last - first) * float(meta["target_scale"])


def decode_target(first: torch.Tensor, x: torch.Tensor, meta: dict[str, Any]) -> torch.Tensor:
    last = x if meta["target"] == "frame" else first + x / float(meta["target_scale"])
    return last.clamp(-1, 1)


def sample_clip(meta: dict[str, Any]) -> dict[str, Any]:
    """The range the sampler clips its clean-target estimate to: the target's own range. A
    residual scaled by s lies in [-2s, 2s]; clipping it to diffusers' default [-1, 1] would cap
    every predicted change at 1/s of the pixel range (nothing in the picture could move)."""
    if meta["target"] == "frame":
        return {"clip_sample": True, "clip_sample_range": 1.0}
    return {"clip_sample": True, "clip_sample_range": 2.0 * float(meta["target_scale"])}


# Names predict_last's sampling procedure; feature caches key on it, so changing how a frame is
# sampled from the same weights must change this.
SAMPLER = "ddim-v2"


def timestep_spacing(scheduler_config: dict[str, Any]) -> str:
    """"trailing" (the first of few steps is the last training timestep, pure noise; one step is
    the model's direct estimate of the target) for v- and sample-prediction. Noise-prediction
    cannot estimate the target from pure noise (it divides by the signal level, ~0 there), so it
    keeps diffusers' default "leading" (10 steps start at t = 900; one step would be t = 0)."""
    return "leading" if scheduler_config.get("prediction_type", "epsilon") == "epsilon" else "trailing"


@torch.no_grad()
def predict_last(unet, scheduler_config: dict[str, Any], meta: dict[str, Any], first: torch.Tensor, context: torch.Tensor, steps: int, seed: int = 0) -> torch.Tensor:
    """Sample the predicted last frame (N, 3, r, r) with `steps` deterministic DDIM steps."""
    from diffusers import DDIMScheduler

    scheduler = DDIMScheduler.from_config(scheduler_config, timestep_spacing=timestep_spacing(scheduler_config), **sample_clip(meta))
    scheduler.set_timesteps(int(steps))
    device = next(unet.parameters()).device
    first, context = first.to(device), context.to(device)
    x = _item_noise(len(first), tuple(first.shape[1:]), seed).to(device) * scheduler.init_noise_sigma
    for t in scheduler.timesteps:
        eps = unet(torch.cat([x, first], dim=1), t, encoder_hidden_states=context).sample
        x = scheduler.step(eps, t, x, eta=0.0).prev_sample
    return decode_target(first, x, meta).cpu()


@torch.no_grad()
def pooled_activations(unet, first: torch.Tensor, context: torch.Tensor, timestep: int, grid: int = 2, seed: int = 0) -> torch.Tensor:
    """One forward pass from pure noise at `timestep`: the mid-block and first up-block
    activations, average-pooled to grid×grid, flattened and joined (N, D)."""
    device = next(unet.parameters()).device
    first, context = first.to(device), context.to(device)
    x = _item_noise(len(first), tuple(first.shape[1:]), seed).to(device)
    grabbed: list[torch.Tensor] = []
    hooks = [
        unet.mid_block.register_forward_hook(lambda _m, _i, out: grabbed.append(out)),
        unet.up_blocks[0].register_forward_hook(lambda _m, _i, out: grabbed.append(out)),
    ]
    try:
        t = torch.full((len(first),), int(timestep), dtype=torch.long, device=device)
        unet(torch.cat([x, first], dim=1), t, encoder_hidden_states=context)
    finally:
        for hook in hooks:
            hook.remove()
    parts = [F.adaptive_avg_pool2d(a[0] if isinstance(a, tuple) else a, grid).flatten(1) for a in grabbed]
    return torch.cat(parts, dim=1).cpu()
