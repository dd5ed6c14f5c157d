"""An isolated, cached Python environment holding `lerobot` (it cannot join xicm's own).

lerobot 0.4.4 pins torch<2.11 and huggingface-hub<0.36, while xicm runs torch 2.13 and
transformers 5. So the LeRobot writer and reader (writer.py, reader.py), the
LeRobot policy server (src/xicm/lerobot/policy_server.py) and lerobot's own training script run
under a separate venv's interpreter, built once per requirement list (src/xicm/lerobot/isolated_env.py):

    <cache>/envs/lerobot-<version>-<hash of the requirement list and the python version>/

Measured here: the only CPU torch wheel on this machine (2.13.0+cpu) has no matching CPU
torchvision anywhere reachable (PyPI's torchvision 0.28.0 links libtorch_cuda.so and fails to
import on the CPU torch: "operator torchvision::nms does not exist"; download.pytorch.org is
unreachable), and lerobot's dataset code imports torchvision. So the env holds the torch,
torchvision and torchcodec that lerobot 0.4.4 itself declares (PyPI's standard builds, which
run on CPU), pinned by a constraint file so no later install moves them. lerobot goes in
with --no-deps (its declared dependencies include robot and teleoperation drivers), then what
its dataset and training modules import (measured), and what xicm's serving package needs.

The env is built in a temp folder beside and renamed into place (a half-built env is never
used), under a file lock (two processes never build it at once), and reused afterwards.
Video decoding (torchcodec) needs FFmpeg's shared libraries (Debian: `apt-get install ffmpeg`);
torchvision has no VideoReader any more, so lerobot's "pyav" decoding path cannot replace it.
Writing needs no system FFmpeg (PyAV's wheel carries its own).
"""

from __future__ import annotations

import ctypes.util
import subprocess
import sys
from pathlib import Path

from xicm.core.contracts.errors import XicmError
from xicm.lerobot.isolated_env import EnvSpec
from xicm.lerobot.isolated_env import env_python as _env_python

LEROBOT_VERSION = "0.4.4"
#: lerobot 0.4.4's own bounds: torch<2.11, torchvision<0.26, torchcodec<0.11 (matching releases)
CONSTRAINTS = ("torch==2.10.0", "torchvision==0.25.0", "torchcodec==0.10.0")
LEROBOT = EnvSpec(
    name=f"lerobot-{LEROBOT_VERSION}",
    python="python3.11",  # lerobot 0.4.4 needs Python >= 3.10; this machine's and CI's 3.11
    first=(CONSTRAINTS[0],),  # first, alone: the torch the rest must keep
    no_deps=(f"lerobot=={LEROBOT_VERSION}",),  # its declared extras pull robots, teleoperators, ...
    requirements=(
        *CONSTRAINTS[1:],
        # what lerobot.datasets imports at runtime (measured), inside lerobot 0.4.4's declared bounds
        "datasets>=4.0.0,<5.0.0",
        "huggingface-hub>=0.34.2,<0.36.0",
        "av>=15.0.0,<16.0.0",
        "jsonlines>=4.0.0,<5.0.0",
        "draccus==0.10.0",
        "deepdiff>=7.0.1,<9.0.0",
        "termcolor>=2.4.0,<4.0.0",
        "einops>=0.8.0,<0.9.0",
        "opencv-python-headless>=4.9.0,<4.13.0",
        "gymnasium>=1.1.1,<2.0.0",
        "packaging>=24.2,<26.0",
        "imageio>=2.34.0,<3.0.0",
        "accelerate>=1.10.0,<2.0.0",
        # what lerobot.scripts.lerobot_train imports beside (measured: robots need pyserial, the
        # policy factory diffusers, the trainer wandb, offline here)
        "pyserial>=3.5,<4.0",
        "diffusers>=0.27.2,<0.36.0",
        "wandb>=0.24.0,<0.25.0",
        # what xicm's serving package needs to serve a checkpoint (src/xicm/lerobot/policy_server.py)
        "msgpack>=1.0",
        "websockets>=14",
    ),
    constraints=CONSTRAINTS,
    # the torch it kept is the pinned one, and lerobot's dataset and training modules import
    check=(
        "import torch, torchvision; from lerobot.datasets.lerobot_dataset import LeRobotDataset; "
        "import lerobot.scripts.lerobot_train; import msgpack, websockets; "
        f"assert torch.__version__.split('+')[0] == '{CONSTRAINTS[0].split('==')[1]}', torch.__version__"
    ),
)


def env_python(cache: str | Path, log=print) -> Path:
    """The interpreter of the lerobot env under `cache`, building the env first if needed. Only
    `bin/python` is used: console scripts in a venv built elsewhere and moved keep old paths."""
    return _env_python(LEROBOT, cache, log)


def check_ffmpeg() -> None:
    """Decoding the dataset's videos (torchcodec) loads FFmpeg's shared libraries from the system."""
    if ctypes.util.find_library("avcodec") is None:
        raise XicmError(
            "reading the dataset's videos needs FFmpeg's shared libraries, which this machine lacks "
            "(Debian/Ubuntu: apt-get install ffmpeg; scripts/setup.sh installs it)"
        )


def run_script(python: Path, script: str, *args: str) -> None:
    """Run one of this package's env-side scripts (writer.py, ...) with the env's interpreter."""
    path = Path(__file__).with_name(script)
    done = subprocess.run([str(python), str(path), *args], stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["(no output)"])[-1]
        raise XicmError(f"{script} failed in the lerobot environment: {last}")
