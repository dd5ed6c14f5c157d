"""Scripted demonstrations -> the HDF5 demonstration pool (what `xicm-collect` runs).

For each task, episodes 0, 1, 2, ... are tried until `demos_per_task` demos succeeded or
`ceil(demos_per_task * max_attempts_factor)` episodes were tried:

    obs = sim.reset(task, seed, episode)
    objects = detector.detect(obs, obs.object_names)      # first-frame centres, prompt order
    traj = sim.demonstrate()                              # the task's scripted demonstrator
    obs_last = sim.observe()
    key_actions = encoding.key_actions_from_trajectory(traj)

and successful demos are written with the first/last RGB + depth of one camera (the first the
simulator renders: Observation.first_camera). Every
attempt is logged in the file, so a re-run resumes: episodes already written, or whose
scripted demonstration failed, are skipped without simulating them again, and the walk over
episodes reproduces the counts of an uninterrupted run. Episodes that ended with an
exception (a simulator or detector error, possibly a bug since fixed) are tried again.

With `workers > 1` (collect_parallel) episodes run in worker processes (src/xicm/core/execution/worker_pool.py,
shared with xicm-export) that each keep one simulator alive; the parent alone writes the file and commits results in episode order, so
the pool holds the same demos as a sequential run (see collect_walk.py).
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from xicm.core.text import encoding
from xicm.core.execution.collect_walk import Attempt, EpisodeWalk, NoDemo, attempt
from xicm.core.results.dataset import demo_id
from xicm.core.contracts.interfaces import Detector, Simulator
from xicm.core.contracts.types import Demo
from xicm.core.execution.worker_pool import WorkerPool

log = logging.getLogger(__name__)


def record_episode(
    simulator: Simulator, detector: Detector, task: str, seed: int, episode: int, camera: str | None = None
) -> tuple[Demo, str]:
    """Reset, detect, demonstrate and observe one episode -> (demo, note).

    Raises NoDemo (or whatever the simulator raised) when the episode gives no demo.
    The note names task objects the detector did not find (they are left out of the demo).
    """
    obs = simulator.reset(task, seed, episode)
    camera = camera or obs.first_camera()
    if camera is None:
        raise NoDemo("the simulator rendered no camera; the pool stores one camera's pictures")
    if camera not in obs.cameras:
        raise NoDemo(f"no camera '{camera}' in the observation; cameras: {', '.join(obs.cameras)}")
    found = detector.detect(obs, list(obs.object_names))
    objects = {name: tuple(float(v) for v in found[name]) for name in obs.object_names if name in found}
    first = obs.cameras[camera]
    first_rgb, first_depth = np.array(first.rgb, copy=True), np.array(first.depth, copy=True)
    traj = simulator.demonstrate()
    if not traj.success:
        raise NoDemo("the scripted demonstration did not succeed")
    last = simulator.observe(cameras=[camera]).cameras[camera]  # render only what is stored
    key_actions = encoding.key_actions_from_trajectory(traj)
    if not key_actions:
        raise NoDemo("the trajectory has no key frames")
    missing = [name for name in obs.object_names if name not in objects]
    note = f"not detected: {', '.join(missing)}" if missing else ""
    demo = Demo(
        demo_id=demo_id(task, seed, episode),
        task=task,
        instruction=obs.instruction,
        seed=int(seed),
        episode=int(episode),
        objects=objects,
        key_actions=key_actions,
        first_rgb=first_rgb,
        last_rgb=np.array(last.rgb, copy=True),
        first_depth=first_depth,
        last_depth=np.array(last.depth, copy=True),
        trajectory=traj,
    )
    return demo, note


def attempt_episode(
    simulator: Simulator, detector: Detector, task: str, seed: int, episode: int, camera: str | None = None
) -> Attempt:
    """record_episode that never raises: the outcome of one episode, ready to be committed."""
    return attempt(task, episode, lambda: record_episode(simulator, detector, task, seed, episode, camera))


@dataclass
class Collector:
    """What records a pool's demo: a simulator, the detector of its objects, the camera stored."""

    simulator: Simulator
    detector: Detector
    camera: str | None = None

    def close(self) -> None:
        self.simulator.close()


def _collector_from(config: tuple[dict, str | None]) -> Collector:  # a worker's state
    from omegaconf import OmegaConf

    groups, camera = config
    return Collector(*build_collector(OmegaConf.create(groups)), camera)


def _workspace(collector: Collector):
    return collector.simulator.workspace


def _attempt(collector: Collector, task: str, seed: int, episode: int) -> Attempt:
    return attempt_episode(collector.simulator, collector.detector, task, seed, episode, collector.camera)


RESUME = "everything committed so far is in the pool: run the same command again to resume"


def collect(
    simulator: Simulator,
    detector: Detector,
    tasks: Iterable[str],
    demos_per_task: int,
    seed: int,
    out_path: str | Path,
    max_attempts_factor: float = 2,
    progress: bool = True,
    camera: str | None = None,
) -> dict[str, tuple[int, int]]:
    """Collect demos in this process into `out_path`; returns {task: (successes, attempts)}."""
    pool = WorkerPool.in_process(Collector(simulator, detector, camera), "a collection", RESUME)
    return _walk(pool, tasks, demos_per_task, seed, out_path, max_attempts_factor, progress, in_flight=1)


def collect_parallel(
    config: dict,
    tasks: Iterable[str],
    demos_per_task: int,
    seed: int,
    out_path: str | Path,
    workers: int,
    max_attempts_factor: float = 2,
    progress: bool = True,
    camera: str | None = None,
) -> dict[str, tuple[int, int]]:
    """collect() over `workers` processes, each building its simulator and detector once from
    `config` (collector_config(cfg): the run's simulator and detector groups as plain dicts)."""
    pool = WorkerPool(workers, _collector_from, (dict(config), camera), "a collection", RESUME)
    return _walk(pool, tasks, demos_per_task, seed, out_path, max_attempts_factor, progress, in_flight=2 * workers)


def _walk(pool: WorkerPool, tasks, demos_per_task, seed, out_path, max_attempts_factor, progress, in_flight) -> dict[str, tuple[int, int]]:
    with pool:
        workspace = pool.submit(_workspace).result()
        walk = EpisodeWalk(tasks, demos_per_task, seed, max_attempts_factor, in_flight=in_flight)
        return walk.run(lambda task, episode: pool.submit(_attempt, task, seed, episode), out_path, workspace, progress)


def collector_config(cfg) -> dict:
    """The part of a run's config a collection worker builds from (picklable, resolved): the
    simulator and detector groups, and the benchmark's (its `variations` sets the scenes)."""
    from omegaconf import OmegaConf

    return {group: OmegaConf.to_container(cfg[group], resolve=True) for group in ("simulator", "detector", "benchmark")}


def build_collector(cfg) -> tuple[Simulator, Detector]:
    """The simulator (core.build.build_run, without a policy) and the detector that records a demo's objects."""
    from xicm.core.assembly.build import build_run, group_options
    from xicm.core.assembly.plugins import get_registry

    registry = get_registry()
    run = build_run(cfg, registry, with_policy=False)
    try:
        return run.simulator, registry.create("detector", group_options(cfg, "detector"))
    except BaseException:
        run.close()
        raise
