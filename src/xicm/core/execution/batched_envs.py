"""`envs=N`: a run's episodes on N simulators in worker processes, stepped in lockstep, the
policy asked once per round for every environment that waits for actions.

Each environment slot is a driver thread running the ordinary `core.episode.run_episode` with
its own policy instance (built here, with the slot's simulator proxy: src/xicm/core/execution/sim_process.py) and
its own simulator process, so every episode runs exactly as it would alone. The slots' `act`
calls meet in `Lockstep`: once every slot with an episode in progress is waiting for actions,
`Policy.act_batch` answers them all at once (a remote policy sends its requests together, so
a server that batches sees them together). A policy whose instances may act at the same time
(`Policy.acts_concurrently`, X-ICM over an LLM server with several slots) skips the lockstep:
each slot's thread calls its own instance's act, so the slots' LLM requests reach the server
together and it decodes them in one batch, without waiting for the slowest slot's round. Results are handed to the run loop (src/xicm/core/execution/run_loop.py) in key order,
as the Ray shards do, from a bounded window of keys run ahead (src/xicm/core/execution/keyed_window.py).
"""

from __future__ import annotations

import threading
from typing import Any

from omegaconf import DictConfig, OmegaConf

from xicm.core.assembly.build import Run
from xicm.core.contracts.interfaces import Policy
from xicm.core.execution.keyed_window import Key, KeyedWindow
from xicm.core.contracts.types import EpisodeResult
WINDOW_PER_ENV = 4  # keys run ahead of the one the run loop asks for, per environment


class Lockstep:
    """Gathers the slots' act() calls and answers them with one act_batch per round."""

    def __init__(self, policies: list[Policy]):
        self.policies = policies
        self.cond = threading.Condition()
        self.live: set[int] = set()
        self.waiting: dict[int, Any] = {}
        self.answers: dict[int, Any] = {}

    def join(self, slot: int) -> None:
        with self.cond:
            self.live.add(slot)

    def leave(self, slot: int) -> None:
        with self.cond:
            self.live.discard(slot)
            self._flush_if_all_wait()

    def act(self, slot: int, obs) -> list:
        with self.cond:
            self.waiting[slot] = obs
            self._flush_if_all_wait()
            while slot not in self.answers:
                self.cond.wait()
            answer = self.answers.pop(slot)
        if isinstance(answer, BaseException):
            raise answer
        return answer

    def _flush_if_all_wait(self) -> None:
        if not self.waiting or len(self.waiting) < len(self.live):
            return
        slots = sorted(self.waiting)
        peers = [self.policies[s] for s in slots]
        answers = peers[0].act_batch(peers, [self.waiting[s] for s in slots])
        self.answers.update(zip(slots, answers))
        self.waiting.clear()
        self.cond.notify_all()


class SlotPolicy(Policy):
    """A slot's own policy whose act() goes through the lockstep."""

    def __init__(self, inner: Policy, lockstep: Lockstep | None, slot: int):
        self.inner, self.lockstep, self.slot = inner, lockstep, slot

    @property
    def observes(self) -> bool:  # type: ignore[override]
        return getattr(self.inner, "observes", True)

    def on_episode(self, task, seed, episode) -> None:
        self.inner.on_episode(task, seed, episode)

    def reset(self, task, obs, rng) -> None:
        self.inner.reset(task, obs, rng)

    def act(self, obs):
        if self.lockstep is None:  # acts_concurrently: straight to this slot's own instance
            return self.inner.act(obs)
        return self.lockstep.act(self.slot, obs)

    def run_metadata(self) -> dict:
        return self.inner.run_metadata()

    def record(self) -> dict:
        return self.inner.record()


class BatchedEnvs:
    """Callable (task, seed, episode) -> EpisodeResult over `n` environment processes."""

    def __init__(self, cfg: DictConfig, n: int, episode_options: dict[str, Any], order: list[Key]):
        from xicm.core.assembly.build import build_run
        from xicm.core.assembly.plugins import get_registry
        from xicm.core.execution.sim_process import simulator_processes

        registry = get_registry()
        self.options = episode_options
        self.window = KeyedWindow(order, WINDOW_PER_ENV * n)
        self.cond = threading.Condition()  # guards the window and error
        self.error: BaseException | None = None
        simulators = simulator_processes(OmegaConf.to_container(cfg, resolve=True), n, order[0] if order else None)
        self.runs: list[Run] = []
        try:
            for sim in simulators:
                self.runs.append(build_run(cfg, registry, simulator=sim))
        except BaseException:  # build_run closed the simulator it failed with; close the others
            for sim in simulators[len(self.runs) + 1:]:
                sim.close()
            self.close()
            raise
        concurrent = all(run.policy.acts_concurrently for run in self.runs)
        self.lockstep = None if concurrent else Lockstep([run.policy for run in self.runs])
        self.metadata = {**self.runs[0].metadata(), "envs": n}
        if concurrent:
            self.metadata["envs_concurrent"] = True
        self.threads = [
            threading.Thread(target=self._slot, args=(i, SlotPolicy(run.policy, self.lockstep, i)), name=f"env-{i}", daemon=True)
            for i, run in enumerate(self.runs)
        ]
        for t in self.threads:
            t.start()

    def _take(self) -> Key | None:
        with self.cond:
            while self.window.queue and not self.window.has_room() and self.error is None:
                self.cond.wait()
            return None if self.error is not None else self.window.take()

    def _slot(self, slot: int, policy: SlotPolicy) -> None:
        from xicm.core.execution.episode import run_episode

        if self.lockstep is not None:
            self.lockstep.join(slot)
        try:
            while (key := self._take()) is not None:
                result = run_episode(self.runs[slot].simulator, policy, *key, **self.options)
                with self.cond:
                    self.window.done(key, result)
                    self.cond.notify_all()
        except BaseException as exc:  # noqa: BLE001 - a broken worker ends the run, said by __call__
            with self.cond:
                self.error = exc
                self.cond.notify_all()
        finally:
            if self.lockstep is not None:
                self.lockstep.leave(slot)

    def __call__(self, task: str, seed: int, episode: int) -> EpisodeResult:
        key = (task, int(seed), int(episode))
        with self.cond:
            while not self.window.is_ready(key) and self.error is None:
                self.cond.wait()
            if not self.window.is_ready(key):
                raise self.error  # type: ignore[misc]
            result = self.window.pop(key)
            self.cond.notify_all()  # room in the window: a slot may take the next key
            return result

    def close(self) -> None:
        with self.cond:
            self.window.stop()  # slots stop after their current episode
            self.cond.notify_all()
        for t in getattr(self, "threads", []):
            t.join(timeout=60)
        for run in self.runs:
            run.close()
