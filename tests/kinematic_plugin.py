"""The kinematic test simulator (tests/kinematic_sim) taken the way a third-party plugin is: its
folder on the path, where its dist-info folder names the `xicm` entry point and its
hydra_plugins folder adds `simulator=kinematic` to Hydra's search path; nothing is installed."""

import os
import sys
from pathlib import Path

import pytest

FOLDER = Path(__file__).parent / "kinematic_sim"


def kinematic_env() -> dict[str, str]:
    """An environment for a subprocess (xicm-eval, xicm-serve-policy) that finds the plugin."""
    path = os.pathsep.join(p for p in (str(FOLDER), os.environ.get("PYTHONPATH")) if p)
    return dict(os.environ, PYTHONPATH=path, WANDB_MODE="disabled")


@pytest.fixture
def kinematic_registry(monkeypatch):
    """This process's plugin registry rebuilt with the plugin found (both undone afterwards)."""
    from xicm.core.assembly import plugins

    monkeypatch.syspath_prepend(str(FOLDER))
    monkeypatch.setenv("PYTHONPATH", kinematic_env()["PYTHONPATH"])  # for worker processes (spawn)
    registry = plugins.Registry(plugins.make_plugin_manager())
    monkeypatch.setattr(plugins, "_default", registry)
    yield registry
    for name in [m for m in sys.modules if m == "xicm_kinematic" or m.startswith("xicm_kinematic.")]:
        del sys.modules[name]
