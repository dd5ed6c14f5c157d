"""The walk over episodes of a collection, shared by the sequential and parallel collectors.

Per task, episodes 0, 1, 2, ... are tried until `demos_per_task` demos succeeded or the
attempt cap is reached. Episodes run concurrently (in worker processes) and finish in any
order, but their results are *committed* strictly in episode order: a demo is written, and an
attempt logged, exactly when a sequential run would have done so. An episode is started only
if a sequential run must reach it (the demos committed, ready or running are still too few),
so no simulation is wasted, the pool's contents do not depend on the number of workers, and
resuming after a kill reproduces an uninterrupted run.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Iterable
from concurrent.futures import FIRST_COMPLETED, Future, wait
from dataclasses import dataclass, field
from pathlib import Path

from xicm.core.results.dataset import DemoWriter, demo_id
from xicm.core.contracts.types import Demo

log = logging.getLogger(__name__)


@dataclass
class Attempt:
    """The outcome of simulating one episode: a demo, or why there is none."""

    task: str
    episode: int
    demo: Demo | None
    note: str
    error: bool = False  # an exception, not a failed demonstration: tried again on resume


class NoDemo(Exception):
    """An episode that gives no demo (the reason is logged with the attempt)."""


def attempt(task: str, episode: int, record: Callable[[], tuple[object, str]]) -> Attempt:
    """One episode's outcome, ready to be committed: `record()` -> (demo, note); it never
    raises. NoDemo is a failed demonstration; any other exception an error, tried again on resume."""
    try:
        demo, note = record()
    except NoDemo as exc:
        return Attempt(task, int(episode), None, str(exc), error=False)
    except Exception as exc:  # noqa: BLE001 - a failed episode must not stop the run
        return Attempt(task, int(episode), None, f"{type(exc).__name__}: {exc}", error=True)
    return Attempt(task, int(episode), demo, note, error=False)  # type: ignore[arg-type]


@dataclass
class _TaskState:
    name: str
    successes: int = 0
    attempts: int = 0
    next_episode: int = 0  # next episode to look at for dispatch
    commit_episode: int = 0  # next episode whose result is committed
    ready: dict[int, Attempt | str] = field(default_factory=dict)  # episode -> result, or "written"/"failed"
    running: int = 0
    done: bool = False


class EpisodeWalk:
    def __init__(
        self, tasks: Iterable[str], demos_per_task: int, seed: int, max_attempts_factor: float, in_flight: int
    ):
        self.tasks = [_TaskState(t) for t in tasks]
        self.n = int(demos_per_task)
        self.seed = int(seed)
        self.cap = max(self.n, int(math.ceil(self.n * float(max_attempts_factor))))
        self.in_flight = max(1, int(in_flight))

    def run(
        self,
        submit: Callable[[str, int], Future],
        out_path: str | Path,
        workspace,
        progress: bool = True,
        writer=None,
        desc: str = "collect",
    ) -> dict[str, tuple[int, int]]:
        """Drive `submit(task, episode) -> Future[Attempt]` over all tasks; {task: (successes, attempts)}.

        Results go to the pool at `out_path` (a DemoWriter), or to `writer`: any context manager
        with DemoWriter's has / write / log_attempt / attempts (xicm-export's staging folder)."""
        from tqdm.auto import tqdm

        running: dict[Future, _TaskState] = {}
        with writer or DemoWriter(out_path, workspace) as writer, tqdm(
            total=self.n * len(self.tasks), desc=desc, unit="demo", disable=not progress, dynamic_ncols=True
        ) as bar:
            logged = writer.attempts()
            try:
                while True:
                    for state in self.tasks:
                        self._commit(state, writer, bar)
                    self._dispatch(submit, running, writer, logged)
                    if not running:
                        if all(s.done for s in self.tasks):
                            break
                        continue  # only resumed episodes were advanced: commit them
                    finished, _ = wait(list(running), return_when=FIRST_COMPLETED)
                    for future in finished:
                        state = running.pop(future)
                        state.running -= 1
                        attempt = future.result()
                        if not state.done:
                            state.ready[attempt.episode] = attempt
                            bar.set_postfix_str(f"{state.name} e{attempt.episode}", refresh=False)
            finally:
                for future in running:
                    future.cancel()
        return {s.name: (s.successes, s.attempts) for s in self.tasks}

    # ------------------------------------------------------------------ scheduling
    def _dispatch(self, submit, running: dict, writer: DemoWriter, logged: dict) -> None:
        """Start episodes, task by task, while a sequential run could still need them."""
        for state in self.tasks:
            while len(running) < self.in_flight and not state.done and state.next_episode < self.cap:
                pending = sum(1 for r in state.ready.values() if r == "written" or isinstance(r, Attempt) and r.demo)
                if state.successes + pending + state.running >= self.n:
                    break  # enough demos are on their way; more only if one of them fails
                episode = state.next_episode
                state.next_episode += 1
                previous = logged.get((state.name, self.seed, episode))
                if writer.has(demo_id(state.name, self.seed, episode)):
                    state.ready[episode] = "written"
                elif previous is not None and not previous.success and not previous.error:
                    state.ready[episode] = "failed"  # the demonstrator failed here in an earlier run
                else:
                    running[submit(state.name, episode)] = state
                    state.running += 1
            if len(running) >= self.in_flight:
                return

    def _commit(self, state: _TaskState, writer: DemoWriter, bar) -> None:
        """Take results in episode order, as a sequential run would have produced them."""
        while not state.done and state.commit_episode in state.ready:
            episode = state.commit_episode
            result = state.ready.pop(episode)
            state.commit_episode += 1
            state.attempts += 1
            if result == "written":
                state.successes += 1
                bar.update(1)
            elif isinstance(result, Attempt):
                did = demo_id(state.name, self.seed, episode)
                if result.demo is not None:
                    writer.write(result.demo)
                    writer.log_attempt(state.name, self.seed, episode, True, result.note)
                    state.successes += 1
                    bar.update(1)
                elif result.error:
                    log.warning("collect %s: error, retried on resume (%s)", did, result.note)
                    writer.log_attempt(state.name, self.seed, episode, False, result.note, error=True)
                else:
                    log.info("collect %s: no demo (%s)", did, result.note)
                    writer.log_attempt(state.name, self.seed, episode, False, result.note)
            if state.successes >= self.n:
                break
        if not state.done and (state.successes >= self.n or state.commit_episode >= self.cap):
            self._finish(state, bar)

    def _finish(self, state: _TaskState, bar) -> None:
        state.done = True
        state.ready.clear()  # results a sequential run would never have produced
        if state.successes < self.n:
            log.warning(
                "collect %s: only %d of %d demos after %d attempts", state.name, state.successes, self.n, state.attempts
            )
            bar.update(self.n - state.successes)  # keep the bar's total honest
