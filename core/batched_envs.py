"""`envs=N`: a run's episodes on N simulators in worker processes, stepped in lockstep, the
policy asked once per round for every environment that waits for actions.

Each environment slot is a driver thread running the ordinary `core.episode.run_episode` with
its own policy instance (built here, with the slot's simulator proxy: core/sim_process.py) and
its own simulator process, so every episode runs exactly as it would alone. The slots' `act`
calls meet in `Lockstep`: once every slot with an episode in progress is waiting for actions,
`Policy.act_batch` answers them all at once (a remote policy sends its requests together, so
a server that batches sees them together). Results are handed to `run_episodes` in key order,
as the Ray shards do, from a bounded window of keys run ahead.
"""

from __future__ import annotations

import threading
from typing import Any

from omegaconf import DictConfig, OmegaConf

from xicm.core.interfaces import Policy
from xicm.core.types import EpisodeResult

Key = tuple[str, int, int]
WINDOW_PER_ENV = 4  # keys run ahead of the one run_episodes asks for, per environment


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

    def __init__(self, inner: Policy, lockstep: Lockstep, slot: int):
        self.inner, self.lockstep, self.slot = inner, lockstep, slot

    @property
    def observes(self) -> bool:  # type: ignore[override]
        return getattr(self.inner, "observes", True)

    def on_episode(self, task, seed, episode) -> None:
        self.inner.on_episode(task, seed, episode)

    def reset(self, task, obs, rng) -> None:
        self.inner.reset(task, obs, rng)

    def act(self, obs):
        return self.lockstep.act(self.slot, obs)

    def run_metadata(self) -> dict:
        return self.inner.run_metadata()

    def record(self) -> dict:
        return self.inner.record()


class BatchedEnvs:
    """Callable (task, seed, episode) -> EpisodeResult over `n` environment processes."""

    def __init__(self, cfg: DictConfig, n: int, episode_options: dict[str, Any], order: list[Key]):
        from xicm.core.build import build_policy
        from xicm.core.plugins import get_registry
        from xicm.core.sim_process import SimulatorProcess

        registry = get_registry()
        config = OmegaConf.to_container(cfg, resolve=True)
        self.simulators: list[Any] = []
        self.options = episode_options
        self.order = list(order)
        self.position = {k: i for i, k in enumerate(self.order)}
        self.next_key = 0  # index in order of the next key a slot takes
        self.asked = 0  # index in order of the next key run_episodes will ask for
        self.ready: dict[Key, EpisodeResult] = {}
        self.cond = threading.Condition()
        self.error: BaseException | None = None
        try:
            self.simulators = [SimulatorProcess(config) for _ in range(n)]
            if self.order:  # the first render of a process is slow: all at once, before any episode
                warm = [threading.Thread(target=sim.reset, args=self.order[0]) for sim in self.simulators]
                for t in warm:
                    t.start()
                for t in warm:
                    t.join()
            policies = [build_policy(cfg, registry, sim) for sim in self.simulators]
        except BaseException:
            self.close()
            raise
        self.lockstep = Lockstep(policies)
        self.metadata = {"policy": str(cfg.policy.name), **policies[0].run_metadata(), "envs": n}
        self.threads = [
            threading.Thread(target=self._slot, args=(i, SlotPolicy(p, self.lockstep, i)), name=f"env-{i}", daemon=True)
            for i, p in enumerate(policies)
        ]
        for t in self.threads:
            t.start()

    def _take(self) -> Key | None:
        with self.cond:
            while self.next_key < len(self.order) and self.next_key - self.asked >= WINDOW_PER_ENV * len(self.threads):
                self.cond.wait()
            if self.next_key >= len(self.order) or self.error is not None:
                return None
            self.next_key += 1
            return self.order[self.next_key - 1]

    def _slot(self, slot: int, policy: SlotPolicy) -> None:
        from xicm.core.episode import run_episode

        self.lockstep.join(slot)
        try:
            while (key := self._take()) is not None:
                result = run_episode(self.simulators[slot], policy, *key, **self.options)
                with self.cond:
                    self.ready[key] = result
                    self.cond.notify_all()
        except BaseException as exc:  # noqa: BLE001 - a broken worker ends the run, said by __call__
            with self.cond:
                self.error = exc
                self.cond.notify_all()
        finally:
            self.lockstep.leave(slot)

    def __call__(self, task: str, seed: int, episode: int) -> EpisodeResult:
        key = (task, int(seed), int(episode))
        with self.cond:
            self.asked = self.position[key]
            self.cond.notify_all()
            while key not in self.ready and self.error is None:
                self.cond.wait()
            if key not in self.ready:
                raise self.error  # type: ignore[misc]
            self.asked += 1
            self.cond.notify_all()
            return self.ready.pop(key)

    def close(self) -> None:
        with self.cond:
            self.next_key = len(self.order)  # slots stop after their current episode
            self.cond.notify_all()
        for t in getattr(self, "threads", []):
            t.join(timeout=60)
        for sim in self.simulators:
            sim.close()
