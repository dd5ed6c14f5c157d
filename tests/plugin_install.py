"""Installing a plugin package the way a user does, without touching the test environment."""

import os
import subprocess
import sys
from pathlib import Path


def install_beside(source: Path, target: Path) -> dict[str, str]:
    """pip-install the package at `source` into the folder `target` and return an environment
    whose PYTHONPATH puts it beside this one (an existing PYTHONPATH, e.g. a checkout, stays first)."""
    out = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation", "--no-index", "-q",
         "--target", str(target), str(source)],
        capture_output=True, text=True, timeout=300,
    )
    assert out.returncode == 0, out.stderr[-3000:]
    path = os.pathsep.join(p for p in (str(target), os.environ.get("PYTHONPATH")) if p)
    return dict(os.environ, PYTHONPATH=path, WANDB_MODE="disabled")
