"""xicm-export's job: record export.tasks' scripted demos at the control rate (resumable, in
worker processes: src/xicm/core/execution/worker_pool.py, shared with xicm-collect), then write them as one
LeRobot dataset at export.out_dir."""

from __future__ import annotations

import time
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf

from xicm.core.assembly import build, checks
from xicm.core.assembly.collect_job import resolve_workers
from xicm.core.execution.collect_walk import EpisodeWalk
from xicm.core.contracts.errors import ConfigError
from xicm.core.assembly.plugins import get_registry
from xicm.core.execution.worker_pool import WorkerPool
from xicm.export.provenance import Provenance
from xicm.export.staging import Staging, staged_scene


def export_tasks(cfg: DictConfig) -> list[str]:
    """export.tasks, or the seen benchmark's 18 tasks when it is null."""
    if cfg.export.tasks is not None:
        return list(cfg.export.tasks)
    return list(OmegaConf.load(files("xicm.conf").joinpath("benchmark", "seen.yaml").open()).tasks)


def simulator_options(cfg: DictConfig) -> dict:
    """The simulator group with export.cameras as its cameras (only they are built and rendered)."""
    options = build.group_options(cfg, "simulator")
    options["cameras"] = list(cfg.export.cameras)
    return options


def check_export(cfg: DictConfig) -> tuple[list[str], dict]:
    """Every name and value, before anything is simulated (src/xicm/core/assembly/checks.py's EXPORT parts, then a
    per-step control mode); one ConfigError sentence otherwise."""
    registry = get_registry()
    options = simulator_options(cfg)
    tasks = export_tasks(cfg)
    try:
        checks.run_checks(checks.EXPORT, cfg, registry, tasks, simulator_options=options)
    except ConfigError as exc:  # export.cameras travel as simulator.cameras: name the key the user set
        raise ConfigError(str(exc).replace("simulator.cameras", "export.cameras")) from None
    simulator = registry.get("simulator", options["name"])
    if simulator.extra.get("options") is not None:  # the options left out of the YAML take their defaults
        defaults = OmegaConf.structured(simulator.extra["options"])
        options = {"name": options["name"], **OmegaConf.to_container(OmegaConf.merge(defaults, {
            k: v for k, v in options.items() if k != "name"}))}
    if options.get("control_mode") is None:
        raise ConfigError(
            f"simulator '{cfg.simulator.name}' has no per-step control_mode for the dataset's action; "
            "xicm-export needs a simulator with per-step control (Simulator.control_spec)"
        )
    return tasks, options


def run_export(cfg: DictConfig) -> dict:
    tasks, options = check_export(cfg)
    ex = cfg.export
    out_dir = Path(ex.out_dir)
    cameras = list(ex.cameras)
    settings = {  # what staged episodes depend on: resuming with other values would mix them
        "simulator": {k: v for k, v in options.items() if k != "control_mode"},
        "seed": int(ex.seed),
        "columns": 3,  # version of the staged arrays (2: with key_action.pose, 3: with the scene's variation)
    }
    staging = Staging(out_dir.with_name(f"{out_dir.name}.staging"), settings)
    workers = resolve_workers(ex.workers)
    walk = EpisodeWalk(tasks, int(ex.demos_per_task), int(ex.seed), float(ex.max_attempts_factor), in_flight=2 * workers)
    start = time.perf_counter()
    seed = int(ex.seed)
    resume = "every recorded episode is staged: run the same command again to resume"
    with WorkerPool(workers, _recorder_from, (options, cameras), "an export", resume) as pool:
        facts = pool.submit(_facts).result()
        spec = facts["spec"]
        fps = float(spec.control_hz)
        if fps != int(fps):
            raise ConfigError(f"simulator.control_hz must be a whole number of steps per second for a LeRobot dataset (fps), not {fps}")
        counts = walk.run(lambda task, episode: pool.submit(_attempt, task, seed, episode), None, facts["workspace"],
                          bool(cfg.progress), writer=staging, desc="export")
    recorded = time.perf_counter() - start
    episodes = [p for t in tasks for p in staging.episodes(t, int(ex.seed), int(ex.demos_per_task))]
    if not episodes:
        raise ConfigError(f"no scripted demo of {', '.join(tasks)} succeeded: nothing to export")
    from xicm.lerobot.dataset_writer import dataset_size, write_dataset

    recorded_in = {k: v for k, v in options.items() if k != "name"}
    provenance = [Provenance(*staged_scene(p), options["name"], recorded_in).columns() for p in episodes]
    start = time.perf_counter()
    write_dataset(
        out_dir, episodes, repo_id=str(ex.repo_id), fps=int(fps), sizes=facts["sizes"],
        spec=spec, use_videos=bool(ex.use_videos), frames=str(ex.frames),
        vcodec=str(ex.vcodec), cache=cfg.paths.cache, episode_metadata=provenance,
    )
    written = time.perf_counter() - start
    size = dataset_size(out_dir)
    print(f"\nLeRobot dataset: {out_dir}  ({len(episodes)} episodes of {ex.frames} frames, {size / 1e6:.1f} MB; "
          f"recorded in {recorded:.0f} s with {workers} worker{'s' if workers > 1 else ''}, written in {written:.0f} s)")
    print("| task | demos | attempts | scripted success % |\n|---|---:|---:|---:|")
    for task, (ok, attempts) in counts.items():
        print(f"| {task} | {ok} | {attempts} | {100.0 * ok / max(attempts, 1):.1f} |")
    return {"counts": counts, "episodes": len(episodes), "staged": episodes, "bytes": size, "record_s": recorded,
            "write_s": written}


@dataclass
class Recorder:
    """A worker's state: the simulator that records, and the cameras it records."""

    simulator: Any
    cameras: list[str]

    def close(self) -> None:
        self.simulator.close()


def _recorder_from(config: tuple[dict, list[str]]) -> Recorder:
    options, cameras = config
    return Recorder(get_registry().create_simulator(options), cameras)


def _facts(recorder: Recorder) -> dict:
    """What the dataset's layout is read from: the simulator's workspace, control spec and camera sizes."""
    sizes = recorder.simulator.image_sizes()
    return {"workspace": recorder.simulator.workspace, "spec": recorder.simulator.control_spec(),
            "sizes": {c: tuple(sizes[c]) for c in recorder.cameras}}


def _attempt(recorder: Recorder, task: str, seed: int, episode: int):
    from xicm.export.record import attempt_episode

    return attempt_episode(recorder.simulator, task, seed, episode, recorder.cameras)
