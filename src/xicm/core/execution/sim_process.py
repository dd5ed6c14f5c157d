"""A simulator in a worker process, driven from this one over a pipe (xicm-eval envs=N).

`SimulatorProcess` implements the Simulator interface by forwarding each call to a process
that built the run's simulator (`build_run(cfg, with_policy=False)`); the calls of one proxy
are sequential, so N proxies driven from N threads step N simulators in parallel. A
scripted solution stays in the worker (generators do not travel); the proxy iterates it there.
"""

from __future__ import annotations

import multiprocessing as mp
import traceback
from typing import Any

from xicm.core.contracts.errors import XicmError
from xicm.core.contracts.interfaces import Simulator


def _serve(conn, config: dict) -> None:
    from omegaconf import OmegaConf

    from xicm.core.assembly.build import build_run

    try:
        simulator = build_run(OmegaConf.create(config), with_policy=False).simulator
    except BaseException as exc:  # noqa: BLE001 - the parent says why the worker could not start
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
        return
    conn.send(("ok", {"workspace": simulator.workspace}))
    solution = None
    while True:
        try:
            method, args = conn.recv()
        except EOFError:
            break
        if method == "close":
            simulator.close()
            conn.send(("ok", None))
            break
        try:
            if method == "scripted_solution":
                solution, result = simulator.scripted_solution(), None
            elif method == "solution_next":
                result = next(solution, None)
            else:
                result = getattr(simulator, method)(*args)
            conn.send(("ok", result))
        except BaseException as exc:  # noqa: BLE001 - raised again in the parent, where the episode records it
            conn.send(("raise", (exc, traceback.format_exc(limit=3))))


class SimulatorProcess(Simulator):
    def __init__(self, config: dict, context=None):
        ctx = context or mp.get_context("spawn")  # a fresh interpreter: no inherited renderer state
        self._conn, child = ctx.Pipe()
        self.process = ctx.Process(target=_serve, args=(child, config), daemon=True)
        self.process.start()
        child.close()
        status, value = self._conn.recv()
        if status != "ok":
            self.process.join(timeout=10)
            raise XicmError(f"an environment worker could not build its simulator: {value}")
        self.workspace = value["workspace"]

    def _call(self, method: str, *args: Any) -> Any:
        self._conn.send((method, args))
        status, value = self._conn.recv()
        if status == "raise":
            exc, _where = value
            raise exc
        return value

    def task_names(self):
        return self._call("task_names")

    def task_info(self, task):
        return self._call("task_info", task)

    def reset(self, task, seed, episode):
        return self._call("reset", task, seed, episode)

    def reset_state(self, task, seed, episode):
        return self._call("reset_state", task, seed, episode)

    def instruction(self):
        return self._call("instruction")

    def variation(self):
        return self._call("variation")

    def observe(self, cameras=None):
        return self._call("observe", cameras)

    def proprio(self):
        return self._call("proprio")

    def image_sizes(self):
        return self._call("image_sizes")

    def control_spec(self):
        return self._call("control_spec")

    def record_scripted(self, cameras=None):
        return self._call("record_scripted", cameras)

    def execute(self, action):
        return self._call("execute", action)

    def step(self, action):
        return self._call("step", action)

    def is_success(self):
        return self._call("is_success")

    def demonstrate(self):
        return self._call("demonstrate")

    def scripted_solution(self):
        self._call("scripted_solution")
        while (action := self._call("solution_next")) is not None:
            yield action

    def close(self) -> None:
        if self.process.is_alive():
            try:
                self._call("close")
            except (EOFError, OSError):
                pass
            self.process.join(timeout=30)
        if self.process.is_alive():
            self.process.kill()


def simulator_processes(config: dict, n: int, warm_up: tuple[str, int, int] | None = None) -> list[SimulatorProcess]:
    """`n` simulators, each in its own worker process, each reset once to the scene `warm_up`
    (the first render of a process is slow: all at once, before any episode or client's clock;
    a warm-up that fails is left to the episode that resets to that scene to report). All are
    closed again if one fails to start."""
    import contextlib
    import threading

    processes: list[SimulatorProcess] = []
    try:
        for _ in range(n):
            processes.append(SimulatorProcess(config))
    except BaseException:
        for sim in processes:
            sim.close()
        raise
    if warm_up is not None:

        def reset(sim: SimulatorProcess) -> None:
            with contextlib.suppress(Exception):
                sim.reset(*warm_up)

        threads = [threading.Thread(target=reset, args=(sim,)) for sim in processes]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    return processes
