"""The one way from a composed config to a live run: the simulator and the policy paired in it
(`build_run`), whichever way the run executes. The names are checked before, by the command's
check phase (src/xicm/core/assembly/checks.py)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from omegaconf import DictConfig, OmegaConf

from xicm.core.contracts.interfaces import Policy, PolicyContext, Simulator
from xicm.core.assembly.plugins import Registry, get_registry


def group_options(cfg: DictConfig, group: str) -> dict[str, Any]:
    """A config group's options as a plain dict: `name` picks the plugin, the rest are its factory's arguments."""
    data = OmegaConf.to_container(cfg[group], resolve=True)
    assert isinstance(data, dict)
    return data


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


def simulator_for_run(cfg: DictConfig, registry: Registry) -> Simulator:
    """The run's simulator; benchmark.variations (zero | sampled) decides whether episodes use
    variation 0 or one sampled from (seed, task, episode)."""
    simulator = registry.create_simulator(group_options(cfg, "simulator"))
    simulator.sample_variations = cfg.benchmark.variations == "sampled"
    return simulator


def build_run(
    cfg: DictConfig, registry: Registry | None = None, *, with_policy: bool = True, simulator: Simulator | None = None
) -> Run:
    """The one pairing of a simulator with the policy acting in it, for every way a run executes:
    a local run, each Ray actor, xicm-collect and the benchmarks create the simulator here;
    `envs=N` slots and xicm-serve-policy sessions pass `simulator`, a proxy of one in a worker
    process (src/xicm/core/execution/sim_process.py). The simulator is closed if the policy fails to build."""
    registry = registry or get_registry()
    simulator = simulator if simulator is not None else simulator_for_run(cfg, registry)
    if not with_policy:
        return Run(simulator, None)
    try:
        policy = registry.create(
            "policy", group_options(cfg, "policy"), context=PolicyContext(cfg=cfg, registry=registry, simulator=simulator)
        )
    except BaseException:
        simulator.close()
        raise
    return Run(simulator, policy, str(cfg.policy.name))
