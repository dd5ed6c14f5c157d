"""A tiny synthetic pool for dynamics tests: a coloured square slides left or right."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from xicm.core.results.dataset import DemoWriter
from xicm.core.contracts.types import Demo, KeyAction

WORKSPACE = ((-0.3, -0.5, 0.6), (0.7, 0.5, 1.6))
TASKS = {  # task -> (instruction, colour, start column, end column)
    "slide_left": ("slide the red block to the left", (220, 40, 40), 10, 2),
    "slide_right": ("slide the blue block to the right", (40, 40, 220), 2, 10),
}


def frame(colour, column: int, row: int, size: int = 16) -> np.ndarray:
    img = np.full((size, size, 3), 200, np.uint8)
    img[row : row + 4, column : column + 4] = colour
    return img


def write_pool(path: Path, episodes: int = 6) -> Path:
    with DemoWriter(path, WORKSPACE) as w:
        for task, (text, colour, start, end) in TASKS.items():
            for ep in range(episodes):
                row = 2 + 2 * (ep % 5)
                w.write(
                    Demo(
                        demo_id=f"{task}/s0/e{ep:04d}",
                        task=task,
                        instruction=text,
                        seed=0,
                        episode=ep,
                        objects={"block": (0.1, 0.0, 0.8)},
                        key_actions=[KeyAction((0.1, 0.0, 0.8), (0.0, 1.0, 0.0, 0.0), True)],
                        first_rgb=frame(colour, start, row),
                        last_rgb=frame(colour, end, row),
                    )
                )
    return path
