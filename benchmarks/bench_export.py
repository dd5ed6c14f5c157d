"""xicm-export speed and size: frames per second, demos per minute and MB per demo at several
image sizes, and the whole seen set extrapolated from them.

    python benchmarks/bench_export.py [--sizes 128 224] [--demos-per-task 1] [--workers 2]
                                      [--cameras front wrist] [--tasks close_jar ...]

For each size, runs the real export (record at the control rate with rendering, stage, then
lerobot's writer in its env) of `demos-per-task` demos of every task into a fresh folder, and
prints recording and writing rates and dataset bytes per demo. The extrapolation multiplies
the per-task means by demos per task for the 18 seen tasks (10: xicm-export's default; 200:
the AGNOSTOS pool size). The lerobot env must exist or is built first (not timed). With
--replay, the dataset is loaded back with LeRobotDataset and every episode's actions are
replayed through step() in each control mode: the success rate per mode.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[128, 224])
    ap.add_argument("--demos-per-task", type=int, default=1)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 2)
    ap.add_argument("--cameras", nargs="+", default=["front", "wrist"])
    ap.add_argument("--tasks", nargs="*", default=None, help="default: the 18 seen tasks")
    ap.add_argument("--replay", action="store_true", help="also replay the loaded actions in every control mode")
    args = ap.parse_args()

    from hydra import compose, initialize_config_module

    from xicm.lerobot.dataset_writer import dataset_size
    from xicm.export.job import export_tasks, run_export
    from xicm.lerobot.env import env_python

    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        base = compose("config")
    env_python(base.paths.cache)  # build outside the timings
    tasks = args.tasks or export_tasks(base)
    for size in args.sizes:
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "ds"
            with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
                cfg = compose("config", overrides=[
                    f"export.tasks=[{','.join(tasks)}]", f"export.demos_per_task={args.demos_per_task}",
                    f"export.workers={args.workers}", f"export.cameras=[{','.join(args.cameras)}]",
                    f"simulator.image_size={size}", f"export.out_dir={out}", "progress=false",
                ])
            start = time.perf_counter()
            report = run_export(cfg)
            total = time.perf_counter() - start
            staged = report["staged"]  # in the dataset's episode order
            frames = sum(len(np.load(p)["action.ee_delta"]) for p in staged)
            demos = report["episodes"]
            per_task = {}
            for p in staged:
                per_task.setdefault(p.parent.parent.name, []).append(len(np.load(p)["action.ee_delta"]))
            mb = dataset_size(out) / 1e6
            staging_mb = dataset_size(out.with_name("ds.staging")) / 1e6
            print(f"\n## {size} px, cameras {', '.join(args.cameras)}, {args.workers} workers, {len(tasks)} tasks x "
                  f"{args.demos_per_task} demos (machine: {os.cpu_count()} cores)")
            print(f"demos {demos}, frames {frames} (mean {frames / demos:.1f} per demo)")
            print(f"record {report['record_s']:.1f} s: {frames / report['record_s']:.2f} frames/s, "
                  f"{60 * demos / report['record_s']:.2f} demos/min")
            print(f"write (lerobot, encode) {report['write_s']:.1f} s: {frames / report['write_s']:.1f} frames/s")
            print(f"end to end {total:.1f} s: {frames / total:.2f} frames/s, {60 * demos / total:.2f} demos/min")
            print(f"dataset {mb:.2f} MB = {mb / demos:.3f} MB per demo; staging {staging_mb / demos:.3f} MB per demo")
            seconds_per_demo, mb_per_demo = total / demos, mb / demos
            for n in (10, 200):
                print(f"seen set, 18 tasks x {n} demos: ~{18 * n * seconds_per_demo / 3600:.1f} h, "
                      f"~{18 * n * mb_per_demo / 1e3:.2f} GB (dataset), ~{18 * n * staging_mb / demos / 1e3:.2f} GB (staging)")
            if args.replay:
                replay(cfg, out, Path(tmp) / "loaded.npz")


def replay(cfg, out: Path, loaded: Path) -> None:
    """Replay the actions LeRobotDataset loads, per control mode, from each episode's reset (the
    scene its scene/* columns name, in the simulator they name)."""
    from xicm.core.assembly.plugins import get_registry
    from xicm.lerobot.dataset_writer import read_dataset
    from xicm.export.provenance import from_dump

    read_dataset(out, cfg.export.repo_id, loaded, cfg.paths.cache)
    data = np.load(loaded)
    scenes = from_dump(data)
    episode_of = data["column.episode_index"].reshape(-1)
    modes = [key[len("column.action."):] for key in data.files if key.startswith("column.action.")]  # the dataset's own
    for space in modes:  # one export: every episode was recorded with the same simulator options
        options = {"name": scenes[0].simulator, **scenes[0].simulator_options, "render": False, "control_mode": space}
        sim = get_registry().create_simulator(options)
        ok = 0
        for n, scene in enumerate(scenes):
            sim.reset_state(scene.task, scene.seed, scene.episode)
            outcomes = [sim.step(a) for a in data[f"column.action.{space}"][episode_of == n]]
            ok += any(o.success for o in outcomes)
        sim.close()
        print(f"replay {space}: {ok}/{len(scenes)} succeed ({100 * ok / len(scenes):.1f} %)")


if __name__ == "__main__":
    main()
