"""How good predicted last frames are: MSE, SSIM and a side-by-side picture."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.ndimage import gaussian_filter

C1, C2 = (0.01 * 1.0) ** 2, (0.03 * 1.0) ** 2  # SSIM constants for images in [0, 1]


def mse(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per-image mean squared error of uint8 images (N, H, W, 3), on a [0, 1] scale."""
    a, b = a.astype(np.float64) / 255.0, b.astype(np.float64) / 255.0
    return ((a - b) ** 2).reshape(len(a), -1).mean(axis=1)


def ssim(a: np.ndarray, b: np.ndarray, sigma: float = 1.5) -> np.ndarray:
    """Per-image SSIM (Gaussian window, per channel, averaged) of uint8 images (N, H, W, 3)."""
    out = []
    for x, y in zip(a.astype(np.float64) / 255.0, b.astype(np.float64) / 255.0):
        blur = lambda img: gaussian_filter(img, sigma=(sigma, sigma, 0))  # noqa: E731
        mx, my = blur(x), blur(y)
        vx, vy, cxy = blur(x * x) - mx**2, blur(y * y) - my**2, blur(x * y) - mx * my
        s = ((2 * mx * my + C1) * (2 * cxy + C2)) / ((mx**2 + my**2 + C1) * (vx + vy + C2))
        out.append(float(s.mean()))
    return np.asarray(out)


def comparison_picture(path: Path, columns: list[tuple[str, np.ndarray]], titles: list[str]) -> None:
    """One row per demo, one column per (name, images) entry, e.g. first | predicted | real last."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n, m = len(titles), len(columns)
    fig, axes = plt.subplots(n, m, figsize=(2 * m, 2.1 * n), squeeze=False)
    for i in range(n):
        for j, (name, images) in enumerate(columns):
            ax = axes[i, j]
            ax.imshow(images[i], interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            if i == 0:
                ax.set_title(name, fontsize=9)
        axes[i, 0].set_ylabel(titles[i], fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
