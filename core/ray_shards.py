"""Episode-level sharding: `shards.backend=ray` spreads one run's episodes over Ray actors.

Each actor builds the simulator and the policy once (core.build.build_run, as a local run does) and runs the
(task, seed, episode) keys the driver hands it. The driver stays the only writer of
episodes.jsonl: `core.episode_loop.run_episodes` asks for the pending keys one by one, in key
order, and this module answers from a window of keys handed out ahead to the actors. So the
file is written exactly as by a local run (same order, never a duplicate), and a killed run
resumes from the file as usual, losing at most the results still in the window.

Ray is imported only when `shards.backend=ray` is used (`pip install 'xicm[scale]'`).
"""

from __future__ import annotations

import contextlib
import math
import os
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf

from xicm.core.errors import ConfigError, XicmError
from xicm.core.run_dir import RunDir
from xicm.core.types import EpisodeResult

Key = tuple[str, int, int]
RunOne = Callable[[str, int, int], EpisodeResult]

QUEUED_PER_WORKER = 2  # one running + one waiting, so an actor never idles on the driver's round trip
WINDOW_PER_WORKER = 4  # keys handed out but not yet written, per worker: bounds what a kill loses
LOCAL_OBJECT_STORE_BYTES = 200 * 1024**2  # only configs and episode rows travel through it


@dataclass(frozen=True)
class ShardSettings:
    backend: str = "local"
    workers: int = 1
    address: str | None = None  # None: start a local Ray cluster for this run
    cpus_per_worker: float = 1.0


def shard_settings(cfg: DictConfig) -> ShardSettings:
    """The run's `shards` keys (their types and ranges are the config schema's: xicm.core.config_schema)."""
    node = cfg.get("shards")
    if node is None:
        return ShardSettings()
    address = node.get("address")
    settings = ShardSettings(
        str(node.get("backend", "local")),
        int(node.get("workers", 1)),
        None if address in (None, "") else str(address),
        float(node.get("cpus_per_worker", 1.0)),
    )
    if settings.backend == "ray":
        try:
            import ray  # noqa: F401
        except ImportError:
            raise ConfigError("shards.backend=ray needs Ray: pip install 'xicm[scale]'") from None
    return settings


@dataclass
class EpisodeRunner:
    """What run_episodes calls per pending key, and the policy's run metadata (for run.json)."""

    run_one: RunOne
    metadata: dict[str, Any]


@contextlib.contextmanager
def episode_runner(
    settings: ShardSettings, cfg: DictConfig, out_dir: Path, keys: list[Key], **episode_options: Any
) -> Iterator[EpisodeRunner]:
    """Build the run here (`build_run`) and run episodes in this process, or on Ray actors that
    each build their own (the driver then builds nothing). `episode_options` (max_steps, ...) go
    to every `core.episode.run_episode` call, here or in the actors."""
    done = {(r["task"], r["seed"], r["episode"]) for r in RunDir(out_dir).read_episodes()}
    pending = [k for k in keys if k not in done]  # the order run_episodes will ask in
    envs = int(cfg.get("envs", 1) or 1)
    if envs > 1 and pending:
        from xicm.core.batched_envs import BatchedEnvs

        batched = BatchedEnvs(cfg, envs, episode_options, pending)
        try:
            yield EpisodeRunner(batched, batched.metadata)
        finally:
            batched.close()
        return
    if settings.backend == "local" or not pending:  # nothing to run: do not start a cluster
        worker = EpisodeWorker(cfg, episode_options)
        try:
            yield EpisodeRunner(worker.run, worker.metadata())
        finally:
            worker.close()
        return
    shards = RayEpisodeShards(settings, OmegaConf.to_container(cfg, resolve=True), episode_options, pending)
    try:
        yield EpisodeRunner(shards, shards.metadata)
    finally:
        shards.close()


class EpisodeWorker:
    """A simulator and a policy built once (`build_run`), then episode after episode: the local
    runner, and the state of each Ray actor."""

    def __init__(self, config: DictConfig | dict[str, Any], episode_options: dict[str, Any]):
        from xicm.core.build import build_run

        cfg = config if isinstance(config, DictConfig) else OmegaConf.create(config)
        self.episode_options = episode_options
        self.built = build_run(cfg)

    def pid(self) -> int:
        return os.getpid()

    def metadata(self) -> dict[str, Any]:
        return self.built.metadata()

    def run(self, task: str, seed: int, episode: int) -> EpisodeResult:
        from xicm.core.episode import run_episode

        return run_episode(self.built.simulator, self.built.policy, task, seed, episode, **self.episode_options)

    def close(self) -> None:
        self.built.close()


class RayEpisodeShards:
    """Callable (task, seed, episode) -> EpisodeResult backed by `settings.workers` Ray actors.

    Keys are handed out in `order`, each to the actor with the fewest queued, while fewer than
    WINDOW_PER_WORKER x workers results are outstanding or waiting to be asked for.
    """

    def __init__(self, settings: ShardSettings, config: dict[str, Any], episode_options: dict[str, Any], order: list[Key]):
        import ray

        self._ray = ray
        self._started = not ray.is_initialized()
        if self._started:
            self._init_ray(settings)
        self.actors: list[Any] = []
        self.queue: deque[Key] = deque(order)
        self.window = WINDOW_PER_WORKER * settings.workers
        self.in_flight: dict[Any, tuple[Key, int]] = {}  # ObjectRef -> (key, actor index)
        self.queued = [0] * settings.workers
        self.ready: dict[Key, EpisodeResult] = {}
        self.episodes_run = [0] * settings.workers
        self.pids: list[int] = []
        try:
            actor_class = ray.remote(num_cpus=settings.cpus_per_worker)(EpisodeWorker)
            self.actors = [actor_class.remote(config, episode_options) for _ in range(settings.workers)]
            self.pids = self._wait(ray.get, [a.pid.remote() for a in self.actors])  # every actor built
            self.metadata = self._wait(ray.get, self.actors[0].metadata.remote())  # the same in every actor
        except BaseException:
            self.close()
            raise
        where = settings.address or "a local Ray cluster"
        print(f"shards: {settings.workers} Ray workers on {where}, pids {', '.join(map(str, self.pids))}", flush=True)

    def _init_ray(self, settings: ShardSettings) -> None:
        ray = self._ray
        if settings.address is not None:
            _check_reachable(settings.address)
            try:
                ray.init(address=settings.address, log_to_driver=True)
            except (ConnectionError, RuntimeError, ValueError) as exc:
                reason = " ".join(str(exc).split())[:200]
                raise XicmError(
                    f"cannot join the Ray cluster at shards.address={settings.address} ({reason}); use the address "
                    "`ray start --head` printed, or shards.address=null to start a local cluster"
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
        if key not in self.ready and key not in {k for k, _ in self.in_flight.values()}:
            # Asked out of the expected order: run it now, ahead of the window.
            with contextlib.suppress(ValueError):
                self.queue.remove(key)
            self._submit(key)
        while key not in self.ready:
            self._feed()
            finished, _ = self._ray.wait(list(self.in_flight), num_returns=1)
            for ref in finished:
                done_key, index = self.in_flight.pop(ref)
                self.queued[index] -= 1
                self.episodes_run[index] += 1
                self.ready[done_key] = self._wait(self._ray.get, ref)
        result = self.ready.pop(key)
        self._feed()  # keep the actors busy while the driver writes this row
        return result

    def _feed(self) -> None:
        while self.queue and len(self.in_flight) + len(self.ready) < self.window:
            index = min(range(len(self.actors)), key=self.queued.__getitem__)
            if self.queued[index] >= QUEUED_PER_WORKER:
                return
            self._submit(self.queue.popleft(), index)

    def _submit(self, key: Key, index: int | None = None) -> None:
        if index is None:
            index = min(range(len(self.actors)), key=self.queued.__getitem__)
        ref = self.actors[index].run.remote(*key)
        self.in_flight[ref] = (key, index)
        self.queued[index] += 1

    def _wait(self, get, refs):
        """ray.get, with a worker that died or failed to build turned into one sentence."""
        try:
            return get(refs)
        except self._ray.exceptions.RayError as exc:
            text = str(exc).strip()
            cause = text.splitlines()[-1] if text else "no message"  # the worker's own exception line
            raise XicmError(f"a Ray shard worker failed ({type(exc).__name__}: {cause}); re-run to resume") from exc

    def close(self) -> None:
        ray = self._ray
        if self.pids:
            counts = ", ".join(f"pid {p}: {n}" for p, n in zip(self.pids, self.episodes_run))
            print(f"shards: episodes run per worker: {counts}", flush=True)
        with contextlib.suppress(Exception):
            ray.get([a.close.remote() for a in self.actors], timeout=60)
        for actor in self.actors:
            with contextlib.suppress(Exception):
                ray.kill(actor)
        if self._started:
            ray.shutdown()


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
