"""benchmark.instructions: the instruction an episode's policy reads.

`agnostos` keeps the simulator's instruction (AGNOSTOS's own, as evaluated in the paper).
`sampled` replaces the variation-0 instruction with one of the task's variation-0 phrasings
(TaskInfo.phrasings, RLBench's list), drawn once per episode from the episode's own seed stream
"instruction", so the scene and the policy's draws stay as they are.
"""

from __future__ import annotations

import dataclasses
from typing import Callable

from xicm.core.assembly.seeding import episode_rng
from xicm.core.contracts.types import Observation

INSTRUCTION_CHOICES = ("agnostos", "sampled")


def episode_instruction(simulator, obs: Observation, task: str, seed: int, episode: int, mode: str) -> Callable[[Observation], Observation]:
    """A function that gives every observation of the episode its instruction under `mode`."""
    if mode not in INSTRUCTION_CHOICES:
        raise ValueError(f"benchmark.instructions is '{mode}'; allowed: {', '.join(INSTRUCTION_CHOICES)}")
    info = simulator.task_info(task)
    if mode == "agnostos" or obs.instruction != info.instruction:  # another variation keeps its own
        return lambda o: o
    rng = episode_rng(seed, task, episode, stream="instruction")
    phrasings = info.phrasings or (info.instruction,)
    text = phrasings[int(rng.integers(len(phrasings)))]
    return lambda o: dataclasses.replace(o, instruction=text)
