"""The oracle policy: each task's scripted solution, computed from the true simulator state.

Not a method but the benchmark's upper bound (and the proof that a task can be solved with
key-pose actions); it gives the "oracle" row of a report. No pool, retriever or LLM is used.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from xicm.core import encoding
from xicm.core.interfaces import Simulator
from xicm.core.types import EpisodeResult


@dataclass
class OracleAgent:
    simulator: Simulator
    max_steps: int = 25

    def run_episode(self, task: str, seed: int, episode: int) -> EpisodeResult:
        result = EpisodeResult(task=task, seed=seed, episode=episode, success=False, steps=0)
        start = time.perf_counter()
        try:
            self.simulator.reset(task, seed, episode)
            t0 = time.perf_counter()
            result.timings["reset"] = round(t0 - start, 4)
            trajectory = self.simulator.demonstrate()
            result.timings["execute"] = round(time.perf_counter() - t0, 4)
            result.steps = len(encoding.key_actions_from_trajectory(trajectory))
            if result.steps > self.max_steps:
                result.error_kind = "max_steps"
                result.error_message = f"the scripted solution takes {result.steps} key actions (max_steps {self.max_steps})"
            elif trajectory.success:
                result.success = True
            else:
                result.error_kind = "oracle_failed"
                why = getattr(self.simulator, "last_demo_error", None)
                result.error_message = f"the scripted solution did not succeed{': ' + why if why else ''}"
        except Exception as exc:  # noqa: BLE001 - record it, keep the run going
            result.error_kind = "sim_error"
            result.error_message = f"{type(exc).__name__}: {exc}"
        result.timings["total"] = round(time.perf_counter() - start, 4)
        return result
