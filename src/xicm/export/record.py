"""One scripted demo recorded at the control rate -> a StagedEpisode (runs in a worker process).

The simulator's `record_scripted(cameras)` plays the task's scripted solution from the reset
state and returns the control-rate recording with its actions in every per-step control mode;
the columns follow the simulator's `control_spec()`.
"""

from __future__ import annotations

import numpy as np

from xicm.core.text import encoding
from xicm.core.execution.collect_walk import Attempt, NoDemo, attempt
from xicm.core.contracts.interfaces import Simulator
from xicm.export import features as feats
from xicm.export.staging import StagedEpisode


def record_episode(simulator: Simulator, task: str, seed: int, episode: int, cameras: list[str]) -> StagedEpisode:
    spec = simulator.control_spec()
    simulator.reset(task, seed, episode)
    variation = simulator.variation()
    recording = simulator.record_scripted(cameras=list(cameras))
    if not recording.success:
        raise NoDemo("the scripted demonstration did not succeed")
    arrays: dict[str, np.ndarray] = {}
    for mode in spec.mode_names(per_step=True):
        arrays[f"action.{mode}"] = np.asarray(recording.actions[mode], dtype=np.float32)
    steps = len(arrays[f"action.{spec.control_mode}"])
    if steps == 0 or not recording.key_actions:
        raise NoDemo("the recording has no control steps or no key actions")
    for camera in cameras:  # the picture before each step (the final state's is not a frame)
        arrays[feats.image_key(camera)] = np.asarray(recording.rgb[camera][:steps], dtype=np.uint8)
    arrays["observation.state"] = np.concatenate(
        [np.asarray(recording.proprio[part.name], dtype=np.float32).reshape(-1, part.width)[:steps]
         for part in spec.state],
        axis=1,
    )
    arrays.update(key_action_columns(recording.key_action_steps, recording.key_actions, steps, simulator.workspace))
    return StagedEpisode(task, int(seed), int(episode), recording.instruction, variation, arrays)


def key_action_columns(key_steps, key_actions, steps: int, workspace) -> dict[str, np.ndarray]:
    """Per step: the index of the key action it works towards, that key action's pose and 7
    integers, and 1 on the step whose end completes it (`key_steps[k]`, a control-step index)."""
    ends = np.asarray(key_steps, dtype=np.int64)
    index = np.minimum(np.searchsorted(ends, np.arange(steps), side="left"), len(ends) - 1)
    ints = np.array([encoding.action_to_ints(a, workspace) for a in key_actions], dtype=np.int64)
    poses = np.array([[*a.position, *a.quat_wxyz, float(a.gripper_open)] for a in key_actions], dtype=np.float32)
    ends_here = np.zeros(steps, dtype=np.int64)
    ends_here[ends[ends < steps]] = 1
    return {
        "key_action.index": index.reshape(-1, 1),
        "key_action.pose": poses[index],
        "key_action.ints": ints[index],
        "key_action.ends_here": ends_here.reshape(-1, 1),
    }


def attempt_episode(simulator: Simulator, task: str, seed: int, episode: int, cameras: list[str]) -> Attempt:
    """record_episode that never raises: the outcome of one episode, ready to be committed."""
    return attempt(task, episode, lambda: (record_episode(simulator, task, seed, episode, cameras), ""))
