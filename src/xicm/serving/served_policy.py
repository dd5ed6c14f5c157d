"""Any policy the registry builds, answering openpi-style requests (what xicm-serve-policy serves).

The server keeps its own simulator (the policy is built with one, as in an evaluation). When a
request starts an episode ("xicm/episode" with call 0, or another task/seed/episode) the server
starts it as a local evaluation does (core.episode.start_episode): that simulator reset to the
same scene, the episode's instruction (benchmark.instructions), the policy reset with the
episode's own random stream. A policy that observes gets the client's whole
Observation ("xicm/observation"); one that reads the true state instead (the scripted oracle)
gets its own simulator, which the server then moves with the same actions the client executes,
so both stay in the same state (the simulation is deterministic).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from functools import cached_property
from typing import Any

from xicm.core.assembly.build import Run
from xicm.core.execution.episode import start_episode
from xicm.core.contracts.errors import EpisodeFailure
from xicm.core.contracts.spaces import KEY_POSE
from xicm.core.contracts.types import ControlStep, Observation
from xicm.serving.actions import from_actions
from xicm.serving.observation import observation_from_wire


class ServedPolicy:
    def __init__(self, run: Run, instructions: str = "agnostos", scene_seed: int | None = None):
        self.run = run
        self.policy = run.policy
        # benchmark.instructions and benchmark.scene_seed: an episode starts as a local one does
        self.instructions, self.scene_seed = instructions, scene_seed
        self.current: tuple[str, int, int] | None = None
        self.reword: Callable[[Observation], Observation] = lambda o: o

    def metadata(self) -> dict[str, Any]:
        observes = bool(getattr(self.policy, "observes", True))
        return {
            "xicm": {
                "policy": self.run.policy_name,
                "observes": observes,
                "observation": "full" if observes else "none",
                "control_mode": getattr(self.policy, "control_mode", KEY_POSE),
            }
        }

    def infer(self, obs: dict) -> dict:
        ep = obs.get("xicm/episode")
        if not isinstance(ep, dict) or not {"task", "seed", "episode"} <= set(ep):
            raise ValueError("this server serves an xicm policy: each request needs 'xicm/episode' with task, seed, episode and call")
        key = (str(ep["task"]), int(ep["seed"]), int(ep["episode"]))
        observation = observation_from_wire(obs["xicm/observation"]) if "xicm/observation" in obs else None
        if key != self.current or int(ep.get("call", 0)) == 0:
            try:
                observation = self._start(key, observation)
            except EpisodeFailure as failure:  # the scene could not be reset: the client's episode fails with it
                return self._failed(failure)
        elif observation is None:
            observation = self._own_observation()
        else:
            observation = self.reword(observation)
        try:
            actions = self.policy.act(observation)
        except EpisodeFailure as failure:
            return self._failed(failure)
        space, chunk = from_actions(actions)
        if space == "control":  # per-step actions are in the mode the server's simulator steps in
            space = self.step_mode
        if not getattr(self.policy, "observes", True):
            self._follow(actions)
        return {"actions": chunk, "xicm/control_mode": space, "xicm/record": self._record()}

    @cached_property
    def step_mode(self) -> str | None:
        """The control mode per-step actions are in: the one the server's simulator steps in."""
        return self.run.simulator.control_spec().control_mode

    def _start(self, key: tuple[str, int, int], observation: Observation | None) -> Observation:
        """A local episode's start (core.episode.start_episode) on the server's simulator; the
        observation the policy was reset with."""
        start = start_episode(self.run.simulator, self.policy, *key, self.instructions, scene_seed=self.scene_seed,
                              observation=observation)
        self.first_obs, self.reword, self.current = start.scene, start.reword, key
        return start.first

    def _failed(self, failure: EpisodeFailure) -> dict:
        self.current = None
        return {"actions": [], "xicm/failure": {"kind": failure.kind, "message": failure.message}, "xicm/record": self._record()}

    def _own_observation(self):
        return self.first_obs if not getattr(self.policy, "observes", True) else self.reword(self.run.simulator.observe())

    def _follow(self, actions) -> None:
        """Move the server's simulator as the client will, so a state-reading policy stays in step."""
        sim = self.run.simulator
        for action in actions:
            outcome = sim.step(action.values) if isinstance(action, ControlStep) else sim.execute(action)
            if not outcome.ok or outcome.success:
                break

    def _record(self) -> dict:
        try:
            record = self.policy.record()
        except Exception as exc:  # noqa: BLE001 - a record problem must not lose the actions
            return {"extra": {"record_error": f"{type(exc).__name__}: {exc}"}}
        return {k: v for k, v in record.items() if k != "transcript"}


class ServedPolicies:
    """One ServedPolicy per client connection (each evaluation worker runs its own episodes).
    `sessions` are built at start and reused after their connection ends; more are built by
    `build` on need and closed (their simulator process ends) when their connection ends, so a
    burst of clients leaves no process behind. Each session's simulator lives in its own worker
    process (src/xicm/core/execution/sim_process.py), so sessions act in parallel."""

    def __init__(self, build: Callable[[], Run], sessions: int = 1, instructions: str = "agnostos",
                 scene_seed: int | None = None):
        self.build, self.instructions, self.scene_seed = build, instructions, scene_seed
        self.lock = threading.Lock()  # guards the session lists only
        self.idle: list[ServedPolicy] = [self._session(build()) for _ in range(max(1, sessions))]  # built at start
        self.all = list(self.idle)
        self.kept = len(self.all)  # sessions kept between connections

    def _session(self, run: Run) -> ServedPolicy:
        return ServedPolicy(run, self.instructions, self.scene_seed)

    def metadata(self) -> dict[str, Any]:
        return self.all[0].metadata()

    def open_session(self) -> ServedPolicy:
        with self.lock:
            if not self.idle:
                self.idle.append(self._session(self.build()))
                self.all.append(self.idle[-1])
            return self.idle.pop()

    def close_session(self, session: ServedPolicy) -> None:
        with self.lock:
            session.current = None
            extra = len(self.all) > self.kept
            if extra:
                self.all.remove(session)
            else:
                self.idle.append(session)
        if extra:
            session.run.close()  # outside the lock: ending a simulator process takes a moment

    def close(self) -> None:
        for served in self.all:
            served.run.close()
