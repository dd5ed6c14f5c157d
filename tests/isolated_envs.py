"""The isolated environments the `venv` tests run in, built once per machine: the lerobot env
(xicm.lerobot.env) and openpi's own client, which pins numpy < 2, so it is installed there with
--no-deps beside what it imports (test_openpi_client_compat.py)."""

from __future__ import annotations

from pathlib import Path

from xicm.lerobot.isolated_env import EnvSpec, env_python
from xicm.plugins.llms.model_files import cache_root

OPENPI_CLIENT = EnvSpec(
    name="openpi-client",
    python="python3.11",
    no_deps=("openpi-client==0.1.2",),
    requirements=("numpy>=2", "msgpack>=1.0", "websockets>=14", "typing_extensions"),
    check="from openpi_client.websocket_client_policy import WebsocketClientPolicy",
)


def openpi_client_python() -> Path:
    return env_python(OPENPI_CLIENT, cache_root())


def build_all() -> None:
    """Both environments (tests/prebuild.py runs this in the background while the suite runs)."""
    from xicm.lerobot.env import env_python as lerobot_python

    print(openpi_client_python(), flush=True)
    print(lerobot_python(cache_root()), flush=True)
