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

With `workers > 1` (collect_parallel) episodes run in worker processes that each keep one
simulator alive; the parent alone writes the file and commits results in episode order, so
the pool holds the same demos as a sequential run (see collect_walk.py).
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import threading
import time
from collections.abc import Iterable
from concurrent.futures import Future
from pathlib import Path

import numpy as np

from xicm.core import encoding
from xicm.core.collect_walk import Attempt, EpisodeWalk
from xicm.core.dataset import demo_id
from xicm.core.interfaces import Detector, Simulator
from xicm.core.types import Demo

log = logging.getLogger(__name__)


class AttemptFailed(Exception):
    """An episode that gives no demo (the reason is logged in the pool's attempt table)."""


def record_episode(
    simulator: Simulator, detector: Detector, task: str, seed: int, episode: int, camera: str | None = None
) -> tuple[Demo, str]:
    """Reset, detect, demonstrate and observe one episode -> (demo, note).

    Raises AttemptFailed (or whatever the simulator raised) when the episode gives no demo.
    The note names task objects the detector did not find (they are left out of the demo).
    """
    obs = simulator.reset(task, seed, episode)
    camera = camera or obs.first_camera()
    if camera is None:
        raise AttemptFailed("the simulator rendered no camera; the pool stores one camera's pictures")
    if camera not in obs.cameras:
        raise AttemptFailed(f"no camera '{camera}' in the observation; cameras: {', '.join(obs.cameras)}")
    found = detector.detect(obs, list(obs.object_names))
    objects = {name: tuple(float(v) for v in found[name]) for name in obs.object_names if name in found}
    first = obs.cameras[camera]
    first_rgb, first_depth = np.array(first.rgb, copy=True), np.array(first.depth, copy=True)
    traj = simulator.demonstrate()
    if not traj.success:
        raise AttemptFailed("the scripted demonstration did not succeed")
    last = simulator.observe(cameras=[camera]).cameras[camera]  # render only what is stored
    key_actions = encoding.key_actions_from_trajectory(traj)
    if not key_actions:
        raise AttemptFailed("the trajectory has no key frames")
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
    try:
        demo, note = record_episode(simulator, detector, task, seed, episode, camera)
    except AttemptFailed as exc:
        return Attempt(task, int(episode), None, str(exc), error=False)
    except Exception as exc:  # noqa: BLE001 - a failed episode must not stop the run
        return Attempt(task, int(episode), None, f"{type(exc).__name__}: {exc}", error=True)
    return Attempt(task, int(episode), demo, note, error=False)


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

    def run(task: str, episode: int) -> Future:
        done: Future = Future()
        done.set_result(attempt_episode(simulator, detector, task, seed, episode, camera))
        return done

    walk = EpisodeWalk(tasks, demos_per_task, seed, max_attempts_factor, in_flight=1)
    return walk.run(run, out_path, simulator.workspace, progress)


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
    from concurrent.futures import ProcessPoolExecutor
    from concurrent.futures.process import BrokenProcessPool

    context = multiprocessing.get_context("spawn")  # a forked SAPIEN/Vulkan state is not safe
    with ProcessPoolExecutor(
        max_workers=workers,
        mp_context=context,
        initializer=_worker_start,
        initargs=(dict(config), camera),
    ) as pool:
        workspace = pool.submit(_worker_workspace).result()

        def run(task: str, episode: int) -> Future:
            return pool.submit(_worker_attempt, task, seed, episode)

        walk = EpisodeWalk(tasks, demos_per_task, seed, max_attempts_factor, in_flight=2 * workers)
        try:
            return walk.run(run, out_path, workspace, progress)
        except BrokenProcessPool as exc:
            raise RuntimeError(
                "a collection worker process died (see its message above); everything committed so far is "
                "in the pool: run the same command again to resume"
            ) from exc


# --- worker processes: one simulator and detector each, kept for the whole collection ----
_WORKER: dict = {}


def _worker_start(config: dict, camera: str | None) -> None:
    from omegaconf import OmegaConf

    threading.Thread(target=_exit_with_parent, args=(os.getppid(),), daemon=True).start()
    # one software-rendering thread per worker: the workers already fill the cores
    os.environ.setdefault("LP_NUM_THREADS", "1")

    _WORKER["simulator"], _WORKER["detector"] = build_collector(OmegaConf.create(config))
    _WORKER["camera"] = camera


def collector_config(cfg) -> dict:
    """The part of a run's config a collection worker builds from (picklable, resolved)."""
    from omegaconf import OmegaConf

    return {group: OmegaConf.to_container(cfg[group], resolve=True) for group in ("simulator", "detector")}


def build_collector(cfg) -> tuple[Simulator, Detector]:
    """The simulator (core.build.build_run, without a policy) and the detector that records a demo's objects."""
    from xicm.core.build import build_run, group_options
    from xicm.core.plugins import get_registry

    registry = get_registry()
    run = build_run(cfg, registry, with_policy=False)
    try:
        return run.simulator, registry.create("detector", group_options(cfg, "detector"))
    except BaseException:
        run.close()
        raise


def _exit_with_parent(parent: int) -> None:
    """A killed parent (kill -9) cannot stop its workers: they notice being orphaned and exit."""
    while os.getppid() == parent:
        time.sleep(0.5)
    os._exit(1)


def _worker_workspace():
    return _WORKER["simulator"].workspace


def _worker_attempt(task: str, seed: int, episode: int) -> Attempt:
    return attempt_episode(_WORKER["simulator"], _WORKER["detector"], task, seed, episode, _WORKER["camera"])
