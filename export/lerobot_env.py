"""An isolated, cached Python environment holding `lerobot` (it cannot join xicm's own).

lerobot 0.4.4 pins torch<2.11 and huggingface-hub<0.36, while xicm runs torch 2.13 and
transformers 5. So the LeRobot writer and reader (lerobot_writer.py, lerobot_reader.py) run
as plain scripts under a separate venv's interpreter, built once per requirement list:

    <cache>/envs/lerobot-<version>-<hash of the requirement list and the python version>/

Measured here: the only CPU torch wheel on this machine (2.13.0+cpu) has no matching CPU
torchvision anywhere reachable (PyPI's torchvision 0.28.0 links libtorch_cuda.so and fails to
import on the CPU torch: "operator torchvision::nms does not exist"; download.pytorch.org is
unreachable), and lerobot's dataset code imports torchvision. So the env holds the torch,
torchvision and torchcodec that lerobot 0.4.4 itself declares (PyPI's standard builds, which
run on CPU), pinned by a constraint file so no later install moves them. lerobot goes in
with --no-deps (its robot/teleop/training extras are not needed to write or read datasets),
then the runtime needs of its datasets modules.

The env is built in a temp folder beside and renamed into place (a half-built env is never
used), under a file lock (two processes never build it at once), and reused afterwards.
Video decoding (torchcodec) needs FFmpeg's shared libraries (Debian: `apt-get install ffmpeg`);
torchvision has no VideoReader any more, so lerobot's "pyav" decoding path cannot replace it.
Writing needs no system FFmpeg (PyAV's wheel carries its own).
"""

from __future__ import annotations

import contextlib
import ctypes.util
import fcntl
import hashlib
import os
import shutil
import subprocess
import time
from pathlib import Path

from xicm.core.errors import XicmError

LEROBOT_VERSION = "0.4.4"
PYTHON = "python3.11"  # lerobot 0.4.4 needs Python >= 3.10; this machine's and CI's 3.11
#: lerobot 0.4.4's own bounds: torch<2.11, torchvision<0.26, torchcodec<0.11 (matching releases)
CONSTRAINTS = ["torch==2.10.0", "torchvision==0.25.0", "torchcodec==0.10.0"]
TORCH = CONSTRAINTS[0]
#: what lerobot.datasets imports at runtime (measured), inside lerobot 0.4.4's declared bounds
REQUIREMENTS = [
    f"lerobot=={LEROBOT_VERSION}",
    *CONSTRAINTS[1:],
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
    "accelerate>=1.10.0,<2.0.0",  # lerobot.utils.utils imports it (measured: the import fails without)
]
READY = "xicm-env-ready"  # written last inside the env: its presence means the build finished


def env_name() -> str:
    text = "\n".join([PYTHON, *CONSTRAINTS, *REQUIREMENTS])
    return f"lerobot-{LEROBOT_VERSION}-{hashlib.sha256(text.encode()).hexdigest()[:12]}"


def env_path(cache: str | Path) -> Path:
    return Path(cache).expanduser() / "envs" / env_name()


def env_python(cache: str | Path, log=print) -> Path:
    """The interpreter of the lerobot env under `cache`, building the env first if needed."""
    final = env_path(cache)
    python = final / "bin" / "python"
    if (final / READY).exists():
        return python
    final.parent.mkdir(parents=True, exist_ok=True)
    with _locked(final.with_name(f".{final.name}.lock")):
        if not (final / READY).exists():  # another process may have built it meanwhile
            _build(final, log)
    return python


@contextlib.contextmanager
def _locked(lock_path: Path):
    with open(lock_path, "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def _build(final: Path, log) -> None:
    base = shutil.which(PYTHON)
    if base is None:
        raise XicmError(f"cannot build the lerobot environment: no `{PYTHON}` on PATH (lerobot {LEROBOT_VERSION} needs it)")
    tmp = final.with_name(f".{final.name}.tmp")
    shutil.rmtree(tmp, ignore_errors=True)  # the leftover of a killed build
    shutil.rmtree(final, ignore_errors=True)  # a folder without READY is not an env
    start = time.perf_counter()
    log(f"building the lerobot {LEROBOT_VERSION} environment in {final} (once per machine; a few minutes)")
    build_log = final.with_name(f"{final.name}.build.log")
    try:
        _run([base, "-m", "venv", str(tmp)], build_log)
        pip = [str(tmp / "bin" / "python"), "-m", "pip", "install", "--disable-pip-version-check"]
        _run([*pip, TORCH], build_log)  # first: the CPU wheel, before anything can ask for torch
        constraints = tmp / "constraints.txt"
        constraints.write_text("\n".join(CONSTRAINTS) + "\n")
        env = {**os.environ, "PIP_CONSTRAINT": str(constraints)}
        # lerobot's declared dependencies pin an older torch: install it alone, then what it uses
        _run([*pip, "--no-deps", REQUIREMENTS[0]], build_log, env)
        _run([*pip, *REQUIREMENTS[1:]], build_log, env)
        _run([str(tmp / "bin" / "python"), "-c", _CHECK], build_log, env)
        (tmp / READY).write_text(f"built in {time.perf_counter() - start:.0f} s\n")
        os.replace(tmp, final)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    log(f"lerobot environment ready ({time.perf_counter() - start:.0f} s); build log: {build_log}")


#: run inside the fresh env: the torch it kept is the pinned one, and lerobot's dataset class imports
_CHECK = (
    "import torch, torchvision; from lerobot.datasets.lerobot_dataset import LeRobotDataset; "
    f"assert torch.__version__.split('+')[0] == '{TORCH.split('==')[1]}', torch.__version__"
)


def _run(cmd: list[str], build_log: Path, env: dict | None = None) -> None:
    with open(build_log, "a") as out:
        out.write(f"$ {' '.join(cmd)}\n")
        out.flush()
        done = subprocess.run(cmd, stdout=out, stderr=subprocess.STDOUT, env=env)
    if done.returncode != 0:
        tail = build_log.read_text(errors="replace").strip().splitlines()[-1:] or [""]
        raise XicmError(
            f"building the lerobot environment failed at `{' '.join(cmd[-3:])}` ({tail[0].strip()}); "
            f"full output in {build_log}"
        )


def check_ffmpeg() -> None:
    """Decoding the dataset's videos (torchcodec) loads FFmpeg's shared libraries from the system."""
    if ctypes.util.find_library("avcodec") is None:
        raise XicmError(
            "reading the dataset's videos needs FFmpeg's shared libraries, which this machine lacks "
            "(Debian/Ubuntu: apt-get install ffmpeg; scripts/setup.sh installs it)"
        )


def run_script(python: Path, script: str, *args: str) -> None:
    """Run one of this package's env-side scripts (lerobot_writer.py, ...) with the env's interpreter."""
    path = Path(__file__).with_name(script)
    done = subprocess.run([str(python), str(path), *args], stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["(no output)"])[-1]
        raise XicmError(f"{script} failed in the lerobot environment: {last}")
