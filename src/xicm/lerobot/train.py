"""xicm-train-lerobot: train a LeRobot policy on an xicm-export dataset with lerobot's own
training script (`lerobot.scripts.lerobot_train`), run in the lerobot environment.

    xicm-train-lerobot DATASET_DIR OUTPUT_DIR [--steps N] [-- more lerobot-train options]
    xicm-train-lerobot DATASET_DIR OUTPUT_DIR --resume [--steps N]   # go on from the last checkpoint

The defaults suit this project's machines: an ACT policy on CPU, no pretrained backbone (no
download), no wandb, no hub upload; every default can be overridden by a lerobot-train option
after `--` (e.g. `-- --policy.device=cuda --batch_size=64`). The checkpoints land in
OUTPUT_DIR/checkpoints/<step>/pretrained_model, which xicm-serve-lerobot serves.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

#: a small ACT that trains on 2 CPU cores (lerobot's defaults are sized for GPUs)
SMALL_ACT = (
    "--policy.type=act", "--policy.dim_model=128", "--policy.n_heads=4", "--policy.dim_feedforward=512",
    "--policy.n_encoder_layers=2", "--policy.n_vae_encoder_layers=2", "--policy.chunk_size=20",
    "--policy.n_action_steps=20",
)
# `python -P -m`: the working directory stays off sys.path, so a run started in a folder that holds
# one named lerobot (xicm's root did before the src layout) imports the real lerobot
LEROBOT_TRAIN = ("-P", "-m", "lerobot.scripts.lerobot_train")
FIXED = ("--policy.push_to_hub=false", "--policy.pretrained_backbone_weights=null", "--wandb.enable=false")


def train_command(python: Path, dataset: Path, output: Path, steps: int, batch_size: int, device: str, extra: list[str]) -> list[str]:
    repo_id = f"xicm/{dataset.name}"  # a name only: the data is read from dataset.root
    return [
        str(python), *LEROBOT_TRAIN,
        f"--dataset.repo_id={repo_id}", f"--dataset.root={dataset}", f"--output_dir={output}",
        f"--steps={steps}", f"--batch_size={batch_size}", f"--policy.device={device}", "--num_workers=0",
        f"--save_freq={steps}", "--log_freq=50", *SMALL_ACT, *FIXED, *extra,  # later options win
    ]


def resume_command(python: Path, output: Path, steps: int | None, extra: list[str]) -> list[str]:
    """lerobot-train's own resume: the run's saved config, optimizer and step, from checkpoints/last
    (--steps raises the total, e.g. to train further than first planned)."""
    config = output / "checkpoints" / "last" / "pretrained_model" / "train_config.json"
    more = [f"--steps={steps}"] if steps is not None else []
    return [str(python), *LEROBOT_TRAIN, f"--config_path={config}", "--resume=true", *more, *extra]


def main() -> None:
    from xicm.lerobot.env import env_python

    argv = sys.argv[1:]
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    argv = argv[: argv.index("--")] if "--" in argv else argv
    parser = argparse.ArgumentParser(prog="xicm-train-lerobot", description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset", type=Path, help="a dataset folder written by xicm-export (meta/info.json inside)")
    parser.add_argument("output", type=Path, help="lerobot-train's output_dir (must not exist yet)")
    parser.add_argument("--steps", type=int, default=None, help="total optimizer steps (default 5000; with --resume: the run's own)")
    parser.add_argument("--resume", action="store_true", help="continue OUTPUT's run from its last checkpoint")
    parser.add_argument("--batch-size", type=int, default=8)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--cache", default=os.environ.get("XICM_CACHE", str(Path.home() / ".cache" / "xicm")))
    args = parser.parse_args(argv)
    if not (args.dataset / "meta" / "info.json").is_file():
        parser.exit(2, f"xicm-train-lerobot: error: {args.dataset} is not a LeRobot dataset (no meta/info.json)\n")
    if (args.steps is not None and args.steps < 1) or args.batch_size < 1:
        parser.exit(2, "xicm-train-lerobot: error: --steps and --batch-size must be >= 1\n")
    output = args.output.resolve()
    last = output / "checkpoints" / "last" / "pretrained_model" / "train_config.json"
    if args.resume and not last.is_file():
        parser.exit(2, f"xicm-train-lerobot: error: --resume needs a run with a checkpoint, and {last} does not exist\n")
    if not args.resume and output.exists():
        parser.exit(2, f"xicm-train-lerobot: error: {output} exists; --resume continues its run, or choose a new folder\n")
    python = env_python(Path(args.cache).expanduser())  # builds the lerobot environment the first time
    if args.resume:
        cmd = resume_command(python, output, args.steps, extra)
    else:
        cmd = train_command(python, args.dataset.resolve(), output, args.steps or 5000, args.batch_size, args.device, extra)
    # become lerobot-train: stopping this process stops the training (no orphan left running)
    os.execve(cmd[0], cmd, {**os.environ, "HF_HUB_OFFLINE": "1", "WANDB_MODE": "disabled"})
