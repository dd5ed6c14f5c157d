"""xicm-serve-lerobot: serve a LeRobot checkpoint over openpi's websocket protocol from the
lerobot environment (src/xicm/lerobot/env.py builds it once per machine), so `xicm-eval
policy=remote` can evaluate it:

    xicm-serve-lerobot CHECKPOINT [--host H] [--port P] [--control-mode joint_pos] [--api-key-env VAR]

The server script (policy_server.py) runs under that environment's interpreter with
xicm's serving package importable through a one-link folder on PYTHONPATH (the package itself
is not installed there: its other dependencies would clash).
"""

from __future__ import annotations

import argparse
import os
import subprocess
from pathlib import Path

import xicm
from xicm.serving.keys import KeyNotSet, key_from_env
from xicm.serving.limits import add_limit_arguments, limit_arguments


def package_shim(cache: Path) -> Path:
    """A folder holding only a link `xicm` -> this xicm package, for another interpreter's PYTHONPATH."""
    shim = cache / "envs" / "xicm-package-link"
    shim.mkdir(parents=True, exist_ok=True)
    link = shim / "xicm"
    target = Path(xicm.__file__).resolve().parent
    if not link.is_symlink() or link.resolve() != target:
        tmp = shim / f".xicm.{os.getpid()}"
        tmp.unlink(missing_ok=True)
        tmp.symlink_to(target, target_is_directory=True)
        os.replace(tmp, link)  # atomic: another process never sees no link
    return shim


def server_command(python: Path, checkpoint: str, host: str, port: int, control_mode: str | None, device: str,
                   max_batch: int = 1, limits: tuple[str, ...] = ()) -> list[str]:
    """The server script's command line; `limits` are its --api-key-env / --max-sessions /
    --idle-timeout-s arguments as given (a key's variable NAME only: the key stays in the environment)."""
    script = Path(__file__).with_name("policy_server.py")
    cmd = [str(python), str(script), "--checkpoint", str(checkpoint), "--host", host, "--port", str(port),
           "--device", device, "--max-batch", str(max_batch), *limits]
    return cmd + (["--control-mode", control_mode] if control_mode else [])


def server_env(cache: Path) -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(package_shim(cache)), "HF_HUB_OFFLINE": "1"}


def start(python: Path, cache: Path, checkpoint: str, host: str = "127.0.0.1", port: int = 8000,
          control_mode: str | None = None, device: str = "cpu", max_batch: int = 1, limits: tuple[str, ...] = (),
          **popen) -> subprocess.Popen:
    command = server_command(python, checkpoint, host, port, control_mode, device, max_batch, limits)
    return subprocess.Popen(command, env=server_env(cache), **popen)


def main() -> None:
    from xicm.lerobot.env import env_python

    parser = argparse.ArgumentParser(prog="xicm-serve-lerobot", description=__doc__.split("\n\n")[0])
    parser.add_argument("checkpoint", help="a LeRobot pretrained_model folder (lerobot-train writes checkpoints/*/pretrained_model)")
    parser.add_argument("--host", default="127.0.0.1", help="0.0.0.0 to accept other machines")
    parser.add_argument("--port", type=int, default=8000, help="0: any free port (printed)")
    parser.add_argument("--control-mode", default=None, help="the export's simulator.control_mode the checkpoint was trained on (announced to clients)")
    parser.add_argument("--device", default="cpu", help="torch device, e.g. cuda")
    parser.add_argument("--max-batch", type=int, default=1, help="answer up to N concurrent requests (xicm-eval envs=N) in one forward pass")
    add_limit_arguments(parser)
    parser.add_argument("--cache", default=os.environ.get("XICM_CACHE", str(Path.home() / ".cache" / "xicm")), help="where the lerobot environment lives")
    args = parser.parse_args()
    if not (Path(args.checkpoint) / "config.json").is_file():
        parser.exit(2, f"xicm-serve-lerobot: error: {args.checkpoint} is not a LeRobot checkpoint folder (it has no config.json)\n")
    if args.max_batch < 1:
        parser.exit(2, f"xicm-serve-lerobot: error: --max-batch must be >= 1, got {args.max_batch}\n")
    try:
        key_from_env(args.api_key_env, "--api-key-env")  # here, before the lerobot environment loads
    except KeyNotSet as exc:
        parser.exit(2, f"xicm-serve-lerobot: error: {exc}\n")
    cache = Path(args.cache).expanduser()
    command = server_command(env_python(cache), args.checkpoint, args.host, args.port, args.control_mode, args.device,
                             args.max_batch, limit_arguments(args))
    # become the server: `kill PID` (or Ctrl-C) then stops the server itself, never leaving it
    # orphaned on its port
    os.execve(command[0], command, server_env(cache))
