"""The one way from a composed config to a live run: check every name first, then build the
simulator and the policy. xicm-eval, its Ray workers, xicm-collect and the benchmarks all
build through here."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from omegaconf import DictConfig, OmegaConf

from xicm.core.config_schema import XicmConfig
from xicm.core.errors import ConfigError
from xicm.core.interfaces import Policy, PolicyContext, Simulator
from xicm.core.literal_keys import refuse_literal_keys
from xicm.core.plugins import Registry, get_registry
from xicm.core.schema import check_config


def group_options(cfg: DictConfig, group: str) -> dict[str, Any]:
    """A config group's options as a plain dict: `name` picks the plugin, the rest are its factory's arguments."""
    data = OmegaConf.to_container(cfg[group], resolve=True)
    assert isinstance(data, dict)
    return data


def check_run(cfg: DictConfig, registry: Registry, tasks: list[str]) -> None:
    """Raise UnknownPluginError / ConfigError naming what exists or is allowed, before anything is built.

    The config's own keys are checked against xicm.core.config_schema, the simulator's and the
    policy's options against their plugins' schemas. A simulator may register a `check(options)`
    callable for rules between its options. A policy may register a
    `check(cfg, registry)` callable beside its factory to check the groups and files it will
    build from (X-ICM: its parts and its pool).
    """
    refuse_literal_keys(OmegaConf.to_container(cfg, resolve=False))
    check_config(cfg, XicmConfig)
    check_envs(cfg)
    simulator = registry.check_options("simulator", group_options(cfg, "simulator"))
    if simulator.extra.get("check") is not None:  # rules between options, e.g. rates that must divide
        simulator.extra["check"](group_options(cfg, "simulator"))
    policy = registry.check_options("policy", group_options(cfg, "policy"))
    check_tasks(registry, tasks, cfg.simulator.name)
    check = policy.extra.get("check")
    if check is not None:
        check(cfg, registry)


def check_envs(cfg: DictConfig) -> None:
    """envs > 1 steps simulators in worker processes of this machine: not with Ray shards (which
    spread episodes their own way) nor with videos (they record from the simulator's frames here)."""
    envs = int(cfg.get("envs", 1) or 1)
    if envs > 1 and cfg.shards.backend != "local":
        raise ConfigError(f"envs={envs} needs shards.backend=local; Ray shards spread episodes their own way (use one or the other)")
    if envs > 1 and cfg.video.enabled:
        raise ConfigError(f"envs={envs} cannot record videos (video.enabled=true): record them with envs=1")


def check_tasks(registry: Registry, tasks: list[str], simulator: str) -> None:
    """Every task is registered for the chosen simulator (ConfigError naming those that are)."""
    known = list(registry.tasks(simulator=simulator))
    unknown = [t for t in tasks if t not in known]
    if unknown:
        raise ConfigError(
            f"unknown task {', '.join(repr(t) for t in unknown)} for simulator '{simulator}'; available: {', '.join(known)}"
        )


def task_splits(registry: Registry, tasks: list[str]) -> dict[str, str]:
    """Each task's split ('seen', 'level1', 'level2'), from its registration (no simulator needed)."""
    return {t: registry.task_info(t).split for t in tasks}


@dataclass
class Run:
    """A live simulator and, for evaluation, the policy acting in it."""

    simulator: Simulator
    policy: Policy | None
    policy_name: str | None = None

    def metadata(self) -> dict[str, Any]:
        """What run.json records about the policy: its name and whatever the policy reports."""
        if self.policy is None:
            return {}
        return {"policy": self.policy_name, **self.policy.run_metadata()}

    def close(self) -> None:
        self.simulator.close()


def create_simulator(cfg: DictConfig, registry: Registry) -> Simulator:
    """The run's simulator; benchmark.variations (zero | sampled) decides whether episodes use
    variation 0 or one sampled from (seed, task, episode)."""
    simulator = registry.create_simulator(group_options(cfg, "simulator"))
    simulator.sample_variations = cfg.benchmark.variations == "sampled"
    return simulator


def build_run(cfg: DictConfig, registry: Registry | None = None, *, with_policy: bool = True) -> Run:
    """The run's simulator and (with_policy) its policy; the simulator is closed if the policy fails to build."""
    registry = registry or get_registry()
    simulator = create_simulator(cfg, registry)
    if not with_policy:
        return Run(simulator, None)
    try:
        policy = build_policy(cfg, registry, simulator)
    except BaseException:
        simulator.close()
        raise
    return Run(simulator, policy, str(cfg.policy.name))


def build_policy(cfg: DictConfig, registry: Registry, simulator: Simulator) -> Policy:
    """The configured policy, acting in `simulator` (a live one, or a proxy of one in a worker
    process: core/sim_process.py)."""
    return registry.create("policy", group_options(cfg, "policy"), context=PolicyContext(cfg=cfg, registry=registry, simulator=simulator))
