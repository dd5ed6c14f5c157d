"""The worker pool of xicm-collect and xicm-export: processes that each build their state once
(a simulator, and what else records an episode) and then record episode after episode.

`WorkerPool(workers, build, config, ...)` spawns `workers` processes (a forked SAPIEN/Vulkan
state is not safe), each calling `build(config)` once; `submit(fn, *args)` runs
`fn(state, *args)` in one of them and returns its Future. With one worker the state is built,
and `fn` runs, in this process. `build` and `fn` are module-level functions (they travel by
name). Leaving the `with` block shuts the processes down; one that died ends the job with one
sentence saying how to resume.
"""

from __future__ import annotations

import multiprocessing
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from typing import Any

_STATE: list[Any] = []  # in a worker process: the state its build returned


class WorkerPool:
    def __init__(self, workers: int, build: Callable[[Any], Any] | None, config: Any, job: str, resume: str):
        """`job` names the job in the message for a dead worker ("a collection", "an export"),
        `resume` says what is kept and how to go on."""
        self.workers, self.build, self.config, self.job, self.resume = int(workers), build, config, job, resume
        self.state: Any = None
        self.owns_state = True
        self.pool: Any = None

    @classmethod
    def in_process(cls, state: Any, job: str, resume: str) -> "WorkerPool":
        """A pool of one worker: this process, with a state built by the caller (and closed by it)."""
        pool = cls(1, None, None, job, resume)
        pool.state, pool.owns_state = state, False
        return pool

    def __enter__(self) -> "WorkerPool":
        if self.workers == 1:
            if self.state is None:
                self.state = self.build(self.config)
            return self
        from concurrent.futures import ProcessPoolExecutor

        self.pool = ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("spawn"),
                                        initializer=_start, initargs=(self.build, self.config))
        return self

    def submit(self, fn: Callable[..., Any], *args: Any) -> Future:
        if self.pool is not None:
            return self.pool.submit(_call, fn, *args)
        done: Future = Future()
        try:
            done.set_result(fn(self.state, *args))
        except Exception as exc:  # noqa: BLE001 - the caller's .result() raises it, as from a worker
            done.set_exception(exc)
        return done

    def __exit__(self, kind, exc, tb) -> None:
        from concurrent.futures.process import BrokenProcessPool

        if self.pool is not None:
            self.pool.shutdown(cancel_futures=exc is not None)
        elif self.owns_state and self.state is not None:
            self.state.close()
        if isinstance(exc, BrokenProcessPool):
            raise RuntimeError(f"{self.job} worker process died (see its message above); {self.resume}") from exc


def _start(build: Callable[[Any], Any], config: Any) -> None:
    threading.Thread(target=_exit_with_parent, args=(os.getppid(),), daemon=True).start()
    os.environ.setdefault("LP_NUM_THREADS", "1")  # one software-rendering thread per worker: the workers fill the cores
    _STATE[:] = [build(config)]


def _call(fn: Callable[..., Any], *args: Any) -> Any:
    return fn(_STATE[0], *args)


def _exit_with_parent(parent: int) -> None:
    """A killed parent (kill -9) cannot stop its workers: they notice being orphaned and exit."""
    while os.getppid() == parent:
        time.sleep(0.5)
    os._exit(1)
