"""Policy `oracle`: each task's scripted solution, computed from the true simulator state.

Not a method but the benchmark's upper bound (and the proof that a task can be solved with
key-pose actions): the "oracle" row of a report. It needs no pool, retriever or LLM, only a
simulator that implements `scripted_solution()`.
"""

from __future__ import annotations

from dataclasses import dataclass

from xicm.core.contracts.errors import EpisodeFailure
from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.interfaces import Policy, Simulator


class OraclePolicy(Policy):
    observes = False  # it reads the true state: no rendering between steps

    def __init__(self, simulator: Simulator):
        self.simulator = simulator
        self.actions = iter(())

    def reset(self, task, obs, rng) -> None:
        self.actions = self.simulator.scripted_solution()

    def act(self, obs):
        action = next(self.actions, None)
        if action is None:
            raise EpisodeFailure("solution_ended", "the scripted solution ended without success")
        return [action]


@dataclass
class OraclePolicyOptions:
    """No options: the solution comes from the simulator."""


@hookimpl
def register_policies(register):
    register("oracle", lambda options, context: OraclePolicy(context.simulator), options=OraclePolicyOptions)
