"""`xicm-train-dynamics`: the dynamics plugin's own console script (src/xicm/conf/train_dynamics.yaml)."""

from __future__ import annotations

import sys

import hydra
from omegaconf import DictConfig

import xicm.conf  # registers the configs' OmegaConf resolvers and schemas
from xicm.core.contracts.errors import XicmError
from xicm.core.assembly.plugins import UnknownPluginError
from xicm.core.contracts.schema import check_overrides
from xicm.plugins.dynamics.config_schema import TrainDynamicsConfig


def main() -> None:
    """Train the dynamics model of demonstration selection on a pool (resumable)."""
    try:  # a command-line value of the wrong type or range: one sentence, before Hydra composes
        check_overrides(sys.argv[1:], TrainDynamicsConfig, xicm.conf.groups())
    except XicmError as exc:
        _fail(str(exc))
    _train_job()


@hydra.main(version_base="1.3", config_path="../../conf", config_name="train_dynamics")
def _train_job(cfg: DictConfig) -> None:
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
