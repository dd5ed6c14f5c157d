"""Front-camera frames (H, W, 3) uint8 <-> model tensors (N, 3, r, r) in [-1, 1]."""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F


def to_model(frames: list[np.ndarray] | np.ndarray, resolution: int) -> torch.Tensor:
    """Stack frames, resize to resolution×resolution (area averaging) and scale to [-1, 1]."""
    arr = np.stack([np.asarray(f) for f in frames]) if isinstance(frames, list) else np.asarray(frames)
    if arr.ndim != 4 or arr.shape[-1] != 3:
        raise ValueError(f"expected RGB frames of shape (N, H, W, 3), got {arr.shape}")
    x = torch.from_numpy(np.ascontiguousarray(arr)).permute(0, 3, 1, 2).float() / 127.5 - 1.0
    if x.shape[-2:] != (resolution, resolution):
        x = F.interpolate(x, size=(resolution, resolution), mode="area")
    return x


def to_uint8(x: torch.Tensor) -> np.ndarray:
    """(N, 3, r, r) in [-1, 1] -> (N, r, r, 3) uint8."""
    x = ((x.detach().float().clamp(-1, 1) + 1.0) * 127.5).round().to(torch.uint8)
    return x.permute(0, 2, 3, 1).cpu().numpy()
