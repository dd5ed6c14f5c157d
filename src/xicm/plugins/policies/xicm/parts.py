"""X-ICM's parts, built from the run's config groups: detector, encoder, retriever, prompt
builder and LLM (behind the response cache), and the demonstration pool they select from."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf

from xicm.core.results.dataset import require_pool
from xicm.core.contracts.errors import ConfigError
from xicm.core.assembly.plugins import Registry

#: the config groups X-ICM builds its parts from (group name = plugin family)
PART_GROUPS = ("detector", "encoder", "retriever", "prompt", "llm")


def part_options(cfg: DictConfig, group: str) -> dict[str, Any]:
    data = OmegaConf.to_container(cfg[group], resolve=True)
    assert isinstance(data, dict)
    return data


def check_parts(cfg: DictConfig, registry: Registry, pool: str) -> None:
    """Every part's plugin exists and takes its options, and the pool file is there (before anything is built)."""
    for group in PART_GROUPS:
        options = part_options(cfg, group)
        if options.get("name") is None and group == "encoder":  # retrievers that need no encoder
            continue
        registry.check_options(group, options)
    require_pool(pool)


def load_demos(path: str | Path, tasks: list[str], keyframes: str = "ours"):
    """The pool's demos of `tasks`; keyframes: xicm re-derives their key actions from the stored
    trajectories under X-ICM's key-frame rule (rederive_key_actions)."""
    from xicm.core.results.dataset import load_pool

    pool = load_pool(path, tasks=tasks, with_images=True, with_trajectories=keyframes != "ours")
    if not pool:
        raise ConfigError(f"the pool {path} holds no demos of {tasks}; collect them first")
    if keyframes != "ours":
        rederive_key_actions(pool, keyframes, str(path))
    return pool


def rederive_key_actions(demos, rule: str, where: str = "the pool") -> list[str]:
    """Replace each demo's key actions by those of key-frame rule `rule` (src/xicm/core/text/encoding.py) where
    its key frames differ from the pool's rule ("ours"); the ids of the demos that changed.
    Trajectories are dropped afterwards (only the key actions are needed)."""
    from xicm.core.text import encoding

    changed = []
    for demo in demos:
        traj = demo.trajectory
        if traj is None:
            raise ConfigError(
                f"demo {demo.demo_id} of {where} has no stored trajectory, so policy.keyframes={rule} "
                "cannot re-derive its key frames; collect the pool again or use policy.keyframes=ours"
            )
        ours = encoding.keyframe_indices(traj.joint_velocities, traj.gripper_open)
        if encoding.keyframe_indices(traj.joint_velocities, traj.gripper_open, rule=rule) != ours:
            demo.key_actions = encoding.key_actions_from_trajectory(traj, rule=rule)
            changed.append(demo.demo_id)
        demo.trajectory = None
    return changed


def build_encoder(cfg: DictConfig, registry: Registry):
    opts = part_options(cfg, "encoder")
    return None if opts.get("name") is None else registry.create("encoder", opts)


def build_retriever(cfg: DictConfig, registry: Registry, encoder):
    return registry.create("retriever", part_options(cfg, "retriever"), encoder=encoder)


def build_llm(cfg: DictConfig, registry: Registry):
    """The configured LLM, behind the SQLite response cache when it decodes deterministically."""
    llm = registry.create("llm", part_options(cfg, "llm"))
    check_ready = getattr(llm, "check_ready", None)  # plugins written before it existed lack it
    if check_ready is not None:
        check_ready()
    if cfg.llm_cache.enabled and llm.deterministic:
        from xicm.plugins.policies.xicm.llm_cache import CachedLLM

        llm = CachedLLM(llm, cfg.llm_cache.path, enabled=True)
    return llm
