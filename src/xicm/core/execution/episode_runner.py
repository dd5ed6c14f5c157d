"""The dispatcher: which way a run's pending episodes execute, and the object the episode loop
asks for each key's result.

    envs > 1                   BatchedEnvs: N simulator processes in lockstep (src/xicm/core/execution/batched_envs.py)
    shards.backend=local       EpisodeWorker here: one simulator and policy (core.build.build_run)
    shards.backend=ray         RayEpisodeShards: N actors, each an EpisodeWorker (src/xicm/core/execution/ray_shards.py)

Every way pairs its simulators with their policies through `core.build.build_run` and runs each
episode through `core.episode.run_episode`; the batched and Ray ways run keys ahead and hand
results back in key order (src/xicm/core/execution/keyed_window.py). Ray is imported only for shards.backend=ray.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf

from xicm.core.assembly.config_schema import Shards
from xicm.core.execution.keyed_window import Key
from xicm.core.results.run_dir import RunDir
from xicm.core.contracts.types import EpisodeResult

RunOne = Callable[[str, int, int], EpisodeResult]


@dataclass
class EpisodeRunner:
    """What the episode loop calls per pending key, and the policy's run metadata (for run.json)."""

    run_one: RunOne
    metadata: dict[str, Any]


def shard_options(cfg: DictConfig) -> Shards:
    """The run's typed `shards` options (values and defaults: xicm.core.assembly.config_schema, src/xicm/conf/config.yaml)."""
    node = OmegaConf.to_object(cfg.shards)
    return node if isinstance(node, Shards) else Shards(**node)


@contextlib.contextmanager
def episode_runner(cfg: DictConfig, out_dir: Path, keys: list[Key], **episode_options: Any) -> Iterator[EpisodeRunner]:
    """Run the keys not yet in out_dir's episodes.jsonl the way the config says. `episode_options`
    (max_steps, ...) go to every `core.episode.run_episode` call, wherever it runs."""
    done = {(r["task"], r["seed"], r["episode"]) for r in RunDir(out_dir).read_episodes()}
    pending = [k for k in keys if k not in done]  # the order the episode loop will ask in
    envs = int(cfg.envs)
    shards = shard_options(cfg)
    if envs > 1 and pending:
        from xicm.core.execution.batched_envs import BatchedEnvs

        runner: Any = BatchedEnvs(cfg, envs, episode_options, pending)
        call, metadata = runner, runner.metadata
    elif shards.backend == "ray" and pending:  # nothing to run: do not start a cluster
        from xicm.core.execution.ray_shards import RayEpisodeShards

        runner = RayEpisodeShards(shards, OmegaConf.to_container(cfg, resolve=True), episode_options, pending)
        call, metadata = runner, runner.metadata
    else:
        runner = EpisodeWorker(cfg, episode_options)
        call, metadata = runner.run, runner.metadata()
    try:
        yield EpisodeRunner(call, metadata)
    finally:
        runner.close()


class EpisodeWorker:
    """A simulator and a policy built once (`build_run`), then episode after episode: the local
    runner, and the state of each Ray actor."""

    def __init__(self, config: DictConfig | dict[str, Any], episode_options: dict[str, Any]):
        from xicm.core.assembly.build import build_run

        cfg = config if isinstance(config, DictConfig) else OmegaConf.create(config)
        self.episode_options = episode_options
        self.built = build_run(cfg)

    def metadata(self) -> dict[str, Any]:
        return self.built.metadata()

    def run(self, task: str, seed: int, episode: int) -> EpisodeResult:
        from xicm.core.execution.episode import run_episode

        return run_episode(self.built.simulator, self.built.policy, task, seed, episode, **self.episode_options)

    def close(self) -> None:
        self.built.close()
