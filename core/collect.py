"""Scripted demonstrations -> the HDF5 demonstration pool (what `xicm-collect` runs).

For each task, episodes 0, 1, 2, ... are tried until `demos_per_task` demos succeeded or
`ceil(demos_per_task * max_attempts_factor)` episodes were tried:

    obs = sim.reset(task, seed, episode)
    objects = detector.detect(obs, obs.object_names)      # first-frame centres, prompt order
    traj = sim.demonstrate()                              # the task's scripted demonstrator
    obs_last = sim.observe()
    key_actions = encoding.key_actions_from_trajectory(traj)

and successful demos are written with the first/last RGB + depth of one camera. Every
attempt is logged in the file, so a re-run resumes: episodes already written, or whose
scripted demonstration failed, are skipped without simulating them again, and the walk over
episodes reproduces the counts of an uninterrupted run. Episodes that ended with an
exception (a simulator or detector error, possibly a bug since fixed) are tried again.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from xicm.core import encoding
from xicm.core.dataset import DemoWriter, demo_id
from xicm.core.interfaces import Detector, Simulator
from xicm.core.types import Demo

log = logging.getLogger(__name__)


class AttemptFailed(Exception):
    """An episode that gives no demo (the reason is logged in the pool's attempt table)."""


def record_episode(
    simulator: Simulator, detector: Detector, task: str, seed: int, episode: int, camera: str = "front"
) -> tuple[Demo, str]:
    """Reset, detect, demonstrate and observe one episode -> (demo, note).

    Raises AttemptFailed (or whatever the simulator raised) when the episode gives no demo.
    The note names task objects the detector did not find (they are left out of the demo).
    """
    obs = simulator.reset(task, seed, episode)
    if camera not in obs.cameras:
        raise AttemptFailed(f"no camera '{camera}' in the observation; cameras: {', '.join(obs.cameras)}")
    found = detector.detect(obs, list(obs.object_names))
    objects = {name: tuple(float(v) for v in found[name]) for name in obs.object_names if name in found}
    first = obs.cameras[camera]
    first_rgb, first_depth = np.array(first.rgb, copy=True), np.array(first.depth, copy=True)
    traj = simulator.demonstrate()
    if not traj.success:
        raise AttemptFailed("the scripted demonstration did not succeed")
    last = simulator.observe().cameras[camera]
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


def collect(
    simulator: Simulator,
    detector: Detector,
    tasks: Iterable[str],
    demos_per_task: int,
    seed: int,
    out_path: str | Path,
    max_attempts_factor: float = 2,
    progress: bool = True,
    camera: str = "front",
) -> dict[str, tuple[int, int]]:
    """Collect demos into `out_path`; returns {task: (successes, attempts)} (resumed ones included)."""
    from tqdm.auto import tqdm

    tasks = list(tasks)
    n = int(demos_per_task)
    cap = max(n, int(math.ceil(n * float(max_attempts_factor))))
    counts: dict[str, tuple[int, int]] = {}
    with DemoWriter(out_path, simulator.workspace) as writer, tqdm(
        total=n * len(tasks), desc="collect", unit="demo", disable=not progress, dynamic_ncols=True
    ) as bar:
        logged = writer.attempts()
        for task in tasks:
            successes = attempts = 0
            episode = 0
            while successes < n and attempts < cap:
                did = demo_id(task, seed, episode)
                previous = logged.get((task, int(seed), episode))
                if writer.has(did):
                    successes += 1
                    bar.update(1)
                elif previous is not None and not previous.success and not previous.error:
                    pass  # the demonstrator failed on this scene in an earlier run: not retried
                else:
                    bar.set_postfix_str(f"{task} e{episode}", refresh=False)
                    try:
                        demo, note = record_episode(simulator, detector, task, seed, episode, camera)
                    except AttemptFailed as exc:
                        log.info("collect %s: no demo (%s)", did, exc)
                        writer.log_attempt(task, seed, episode, False, str(exc))
                    except Exception as exc:  # noqa: BLE001 - a failed episode must not stop the run
                        note = f"{type(exc).__name__}: {exc}"
                        log.warning("collect %s: error, retried on resume (%s)", did, note)
                        writer.log_attempt(task, seed, episode, False, note, error=True)
                    else:
                        writer.write(demo)
                        writer.log_attempt(task, seed, episode, True, note)
                        successes += 1
                        bar.update(1)
                attempts += 1
                episode += 1
            if successes < n:
                log.warning("collect %s: only %d of %d demos after %d attempts", task, successes, n, attempts)
                bar.update(n - successes)  # keep the bar's total honest
            counts[task] = (successes, attempts)
    return counts

