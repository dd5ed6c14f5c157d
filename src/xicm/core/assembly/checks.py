"""The check phase of every command, built from one set of parts. Each part checks one thing
before anything is built or simulated and raises one sentence (ConfigError /
UnknownPluginError) naming what exists or is allowed; each command lists the parts it runs:

    xicm-eval, xicm-serve-policy   RUN: keys, run_modes, simulator, policy_options, tasks, policy_files
    xicm-collect                   COLLECT: keys, simulator, tasks, detector
    xicm-export                    EXPORT: keys, simulator, tasks (src/xicm/export/job.py adds its control-mode rule)
    vla.XicmEnv                    check_simulator_options alone (it has no composed config)
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from omegaconf import DictConfig, OmegaConf

from xicm.core.assembly.build import group_options
from xicm.core.assembly.config_schema import XicmConfig
from xicm.core.contracts.errors import ConfigError
from xicm.core.assembly.literal_keys import refuse_literal_keys
from xicm.core.assembly.plugins import Registry
from xicm.core.contracts.schema import check_config


@dataclass
class CheckInput:
    """What the parts read: the composed config, the registry, the command's tasks and the
    simulator options it will build with (default: the simulator group as configured)."""

    cfg: DictConfig
    registry: Registry
    tasks: list[str]
    simulator_options: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.simulator_options:
            self.simulator_options = group_options(self.cfg, "simulator")


Part = Callable[[CheckInput], None]


def keys(c: CheckInput) -> None:
    """No secret written into the config, and every key and value the config schema allows."""
    refuse_literal_keys(OmegaConf.to_container(c.cfg, resolve=False))
    check_config(c.cfg, XicmConfig)


def run_modes(c: CheckInput) -> None:
    """envs > 1 steps simulators in worker processes of this machine: not with Ray shards (which
    spread episodes their own way) nor with videos (they record from the simulator's frames
    here); shards.backend=ray needs Ray installed."""
    envs, backend = int(c.cfg.envs), str(c.cfg.shards.backend)
    if envs > 1 and backend != "local":
        raise ConfigError(f"envs={envs} needs shards.backend=local; Ray shards spread episodes their own way (use one or the other)")
    if envs > 1 and c.cfg.video.enabled:
        raise ConfigError(f"envs={envs} cannot record videos (video.enabled=true): record them with envs=1")
    if backend == "ray":
        try:
            import ray  # noqa: F401
        except ImportError:
            raise ConfigError("shards.backend=ray needs Ray: pip install 'xicm[scale]'") from None


def simulator(c: CheckInput) -> None:
    check_simulator_options(c.registry, c.simulator_options)


def check_simulator_options(registry: Registry, options: dict[str, Any]) -> None:
    """The simulator's options against its plugin's schema, then the rules between them that
    the plugin registers as `check(options)` (e.g. rates that must divide)."""
    plugin = registry.check_options("simulator", options)
    if plugin.extra.get("check") is not None:
        plugin.extra["check"](options)


def policy_options(c: CheckInput) -> None:
    c.registry.check_options("policy", group_options(c.cfg, "policy"))


def tasks(c: CheckInput) -> None:
    """Every task is registered for the chosen simulator."""
    name = str(c.simulator_options["name"])
    known = list(c.registry.tasks(simulator=name))
    unknown = [t for t in c.tasks if t not in known]
    if unknown:
        raise ConfigError(f"unknown task {', '.join(repr(t) for t in unknown)} for simulator '{name}'; available: {', '.join(known)}")


def policy_files(c: CheckInput) -> None:
    """What the policy will build from, by the `check(cfg, registry)` its plugin registers beside
    its factory (X-ICM: its parts' groups, its pool file, its LLM)."""
    check = c.registry.get("policy", str(c.cfg.policy.name)).extra.get("check")
    if check is not None:
        check(c.cfg, c.registry)


def detector(c: CheckInput) -> None:
    c.registry.check_options("detector", group_options(c.cfg, "detector"))


RUN: tuple[Part, ...] = (keys, run_modes, simulator, policy_options, tasks, policy_files)
COLLECT: tuple[Part, ...] = (keys, simulator, tasks, detector)
EXPORT: tuple[Part, ...] = (keys, simulator, tasks)


def run_checks(parts: Sequence[Part], cfg: DictConfig, registry: Registry, task_names: list[str],
               simulator_options: dict[str, Any] | None = None) -> None:
    checked = CheckInput(cfg, registry, list(task_names), dict(simulator_options or {}))
    for part in parts:
        part(checked)


def check_run(cfg: DictConfig, registry: Registry, task_names: list[str]) -> None:
    """xicm-eval's and xicm-serve-policy's check phase (RUN)."""
    run_checks(RUN, cfg, registry, task_names)
