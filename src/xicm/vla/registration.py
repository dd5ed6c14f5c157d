"""Registers every task of the plugin registry with Gymnasium as "xicm/<CamelCaseTask>-v0"."""

from __future__ import annotations

import gymnasium

ENTRY_POINT = "xicm.vla.gym_env:XicmEnv"


def env_id(task: str) -> str:
    """'open_drawer' -> 'xicm/OpenDrawer-v0'."""
    return "xicm/" + "".join(part.capitalize() for part in task.split("_")) + "-v0"


def register_envs(simulator: str = "sapien") -> list[str]:
    """Register (once) an env id per task registered for `simulator`; returns the ids."""
    from xicm.core.assembly.plugins import get_registry

    ids = []
    for task in get_registry().tasks(simulator=simulator):
        ids.append(env_id(task))
        if ids[-1] not in gymnasium.registry:
            gymnasium.register(ids[-1], entry_point=ENTRY_POINT, kwargs={"task": task, "simulator": simulator})
    return ids
