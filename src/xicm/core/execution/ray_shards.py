"""Episode-level sharding: `shards.backend=ray` spreads one run's episodes over Ray actors.

Each actor builds the simulator and the policy once (core.build.build_run, as a local run does) and runs the
(task, seed, episode) keys the driver hands it. The driver stays the only writer of
episodes.jsonl: `core.run_loop.run_all_episodes` asks for the pending keys one by one, in key
order, and this module answers from a window of keys handed out ahead to the actors
(src/xicm/core/execution/keyed_window.py). Which runs use Ray is the dispatcher's choice (src/xicm/core/execution/episode_runner.py). So the
file is written exactly as by a local run (same order, never a duplicate), and a killed run
resumes from the file as usual, losing at most the results still in the window. An actor lost
mid-run (its process or its whole node gone) is dropped and its unfinished keys go to the
others; each row's extra["shard"] names the node and process that ran it.

Ray is imported only when `shards.backend=ray` is used (`pip install 'xicm[scale]'`).
"""

from __future__ import annotations

import contextlib
import math
import os
from typing import Any

from xicm.core.assembly.config_schema import Shards
from xicm.core.execution.episode_runner import EpisodeWorker
from xicm.core.contracts.errors import XicmError
from xicm.core.execution.keyed_window import Key, KeyedWindow
from xicm.core.contracts.types import EpisodeResult

QUEUED_PER_WORKER = 2  # one running + one waiting, so an actor never idles on the driver's round trip
WINDOW_PER_WORKER = 4  # keys handed out but not yet written, per worker: bounds what a kill loses
LOCAL_OBJECT_STORE_BYTES = 200 * 1024**2  # only configs and episode rows travel through it


class RayEpisodeWorker(EpisodeWorker):
    """An actor's state: an EpisodeWorker that also says where it runs."""

    def where(self) -> dict[str, Any]:
        """The Ray node and process this actor runs in (copied into each of its rows' extra["shard"])."""
        import socket

        import ray

        context = ray.get_runtime_context()
        return {"node_id": context.get_node_id(), "node_ip": ray.util.get_node_ip_address(),
                "host": socket.gethostname(), "pid": os.getpid()}


class RayEpisodeShards:
    """Callable (task, seed, episode) -> EpisodeResult backed by `settings.workers` Ray actors.

    Keys are handed out in `order`, each to the actor with the fewest queued, while fewer than
    WINDOW_PER_WORKER x workers results are outstanding or waiting to be asked for.
    """

    def __init__(self, settings: Shards, config: dict[str, Any], episode_options: dict[str, Any], order: list[Key]):
        import ray

        self._ray = ray
        self._started = not ray.is_initialized()
        if self._started:
            self._init_ray(settings)
        self.actors: list[Any] = []
        self.window = KeyedWindow(order, WINDOW_PER_WORKER * settings.workers)
        self.in_flight: dict[Any, tuple[Key, int]] = {}  # ObjectRef -> (key, actor index)
        self.queued = [0] * settings.workers
        self.episodes_run = [0] * settings.workers
        self.alive = [True] * settings.workers
        errors = ray.exceptions
        # A worker's process or node gone (not an exception raised by the episode's code): run its keys elsewhere.
        self._lost_worker_errors = (errors.RayActorError, errors.WorkerCrashedError, errors.NodeDiedError,
                                    errors.ObjectLostError)
        self.where: list[dict[str, Any]] = []
        try:
            actor_class = ray.remote(num_cpus=settings.cpus_per_worker)(RayEpisodeWorker)
            self.actors = [actor_class.remote(config, episode_options) for _ in range(settings.workers)]
            self.where = self._wait(ray.get, [a.where.remote() for a in self.actors])  # every actor built
            self.metadata = self._wait(ray.get, self.actors[0].metadata.remote())  # the same in every actor
        except BaseException:
            self.close()
            raise
        where = settings.address or "a local Ray cluster"
        placed = ", ".join(_worker_name(w) for w in self.where)
        print(f"shards: {settings.workers} Ray workers on {where}: {placed}", flush=True)

    def _init_ray(self, settings: Shards) -> None:
        ray = self._ray
        if settings.address is not None:
            _check_reachable(settings.address)
            try:
                ray.init(address=settings.address, log_to_driver=True)
            except (ConnectionError, RuntimeError, ValueError) as exc:
                reason = " ".join(str(exc).split())[:200]
                token = "" if os.environ.get("RAY_AUTH_MODE") == "token" else (
                    "; a cluster with token authentication (on where `ray start --head` found ~/.ray/auth_token or "
                    "RAY_AUTH_MODE=token) also needs RAY_AUTH_MODE=token and its token (RAY_AUTH_TOKEN or that file) here")
                raise XicmError(
                    f"cannot join the Ray cluster at shards.address={settings.address} ({reason}); use the address "
                    f"`ray start --head` printed, or shards.address=null to start a local cluster{token}"
                ) from None
            return
        needed = math.ceil(settings.workers * settings.cpus_per_worker)
        ray.init(
            address="local",  # a new cluster, even where RAY_ADDRESS or a running one is found
            num_cpus=max(os.cpu_count() or 1, needed),
            include_dashboard=False,
            log_to_driver=True,
            object_store_memory=LOCAL_OBJECT_STORE_BYTES,
        )

    def __call__(self, task: str, seed: int, episode: int) -> EpisodeResult:
        key = (task, int(seed), int(episode))
        while not self.window.is_ready(key):
            if not self.window.is_running(key):
                # Asked out of the expected order, or its worker was lost: run it now, ahead of the window.
                self._submit(self.window.take(key))
            self._feed()
            finished, _ = self._ray.wait(list(self.in_flight), num_returns=1)
            for ref in finished:
                if ref in self.in_flight:  # not dropped with a lost worker
                    self._collect(ref)
        result = self.window.pop(key)
        self._feed()  # keep the actors busy while the driver writes this row
        return result

    def _collect(self, ref) -> None:
        done_key, index = self.in_flight.pop(ref)
        self.queued[index] -= 1
        try:
            result = self._ray.get(ref)
        except self._lost_worker_errors as exc:
            self._lose(index, exc, [done_key])
            return
        except self._ray.exceptions.RayError as exc:
            raise _worker_failed(exc) from exc
        self.episodes_run[index] += 1
        result.extra = {**result.extra, "shard": self.where[index]}
        self.window.done(done_key, result)

    def _lose(self, index: int, exc: Exception, lost: list[Key]) -> None:
        """Drop a lost actor (its process or node gone) and queue its unfinished keys first, in key order."""
        for ref, (key, owner) in list(self.in_flight.items()):
            if owner == index:
                del self.in_flight[ref]
                lost.append(key)
        self.window.put_back(lost)
        self.queued[index] = 0
        self.alive[index] = False
        print(f"shards: lost the Ray worker {_worker_name(self.where[index])} ({type(exc).__name__}); its "
              f"{len(lost)} unfinished episode(s) run again on the {sum(self.alive)} other worker(s)", flush=True)
        if not any(self.alive):
            raise XicmError("every Ray shard worker was lost (their nodes or processes died); re-run to resume")

    def _feed(self) -> None:
        while self.window.has_room():
            index = self._least_loaded()
            if self.queued[index] >= QUEUED_PER_WORKER:
                return
            self._submit(self.window.take(), index)

    def _least_loaded(self) -> int:
        return min((i for i, alive in enumerate(self.alive) if alive), key=self.queued.__getitem__)

    def _submit(self, key: Key, index: int | None = None) -> None:
        if index is None:
            index = self._least_loaded()
        ref = self.actors[index].run.remote(*key)
        self.in_flight[ref] = (key, index)
        self.queued[index] += 1

    def _wait(self, get, refs):
        """ray.get, with a worker that died or failed to build turned into one sentence."""
        try:
            return get(refs)
        except self._ray.exceptions.RayError as exc:
            raise _worker_failed(exc) from exc

    def close(self) -> None:
        ray = self._ray
        if self.where:
            counts = ", ".join(f"{_worker_name(w)}: {n}" for w, n in zip(self.where, self.episodes_run))
            print(f"shards: episodes run per worker: {counts}", flush=True)
        alive = [a for a, ok in zip(self.actors, self.alive) if ok]
        with contextlib.suppress(Exception):
            ray.get([a.close.remote() for a in alive], timeout=60)
        for actor in self.actors:
            with contextlib.suppress(Exception):
                ray.kill(actor)
        if self._started:
            ray.shutdown()


def _worker_failed(exc: Exception) -> XicmError:
    text = str(exc).strip()
    cause = text.splitlines()[-1] if text else "no message"  # the worker's own exception line
    return XicmError(f"a Ray shard worker failed ({type(exc).__name__}: {cause}); re-run to resume")


def _worker_name(where: dict[str, Any]) -> str:
    return f"pid {where['pid']} on node {where['node_ip']} {where['node_id'][:8]}"


def _check_reachable(address: str, timeout_s: float = 5.0) -> None:
    """Fail at once for a HOST:PORT nobody listens on (ray.init would wait for it indefinitely)."""
    import socket

    host, _, port = address.removeprefix("ray://").rpartition(":")
    if not host or not port.isdigit():
        return  # "auto" and other forms are Ray's to resolve
    try:
        socket.create_connection((host, int(port)), timeout=timeout_s).close()
    except OSError as exc:
        raise XicmError(
            f"cannot reach the Ray cluster at shards.address={address} ({exc}); start one there with "
            "`ray start --head`, or set shards.address=null to start a local cluster"
        ) from None
