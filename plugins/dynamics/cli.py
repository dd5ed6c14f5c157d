"""`xicm-train-dynamics`: the dynamics plugin's own console script (conf/train_dynamics.yaml)."""

from __future__ import annotations

import sys

import hydra
from omegaconf import DictConfig

import xicm.conf  # noqa: F401  (registers the configs' OmegaConf resolvers)
from xicm.core.errors import XicmError
from xicm.core.plugins import UnknownPluginError


@hydra.main(version_base="1.3", config_path="../../conf", config_name="train_dynamics")
def main(cfg: DictConfig) -> None:
    """Train the dynamics model of demonstration selection on a pool (resumable)."""
    try:
        from .train import run_training
    except ImportError as exc:
        _fail(f"xicm-train-dynamics needs torch and diffusers ({exc}); pip install 'xicm[dynamics]'")
    try:
        run_training(cfg)
    except (XicmError, UnknownPluginError) as exc:
        _fail(str(exc))


def _fail(message: str) -> None:
    print(f"xicm: error: {message}", file=sys.stderr)
    sys.exit(2)
