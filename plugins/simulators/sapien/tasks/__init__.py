"""The SAPIEN tasks, listed without importing sapien.

Each entry keeps the task's static facts (so `TaskInfo` is available cheaply) and where its class
lives; tests/test_sapien_tasks.py checks that these facts match the task classes.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

from xicm.core.types import TaskInfo


@dataclass(frozen=True)
class TaskRef:
    """A task registered by name; `load_class()` imports the real class (and sapien)."""

    name: str
    split: str
    instruction: str
    object_names: tuple[str, ...]
    target: str  # "module:Class"

    def info(self) -> TaskInfo:
        return TaskInfo(self.name, self.split, self.instruction, self.object_names)

    def load_class(self):
        module, cls = self.target.split(":")
        return getattr(importlib.import_module(module), cls)

    def __call__(self, *args, **kwargs):
        return self.load_class()(*args, **kwargs)


_PKG = "xicm.plugins.simulators.sapien.tasks"

TASKS: dict[str, TaskRef] = {
    ref.name: ref
    for ref in (
        TaskRef(
            "open_drawer",
            "seen",
            "open the top drawer",
            ("top drawer handle", "middle drawer handle", "bottom drawer handle"),
            f"{_PKG}.seen.open_drawer:OpenDrawer",
        ),
        TaskRef(
            "push_buttons",
            "seen",
            "push the red button",
            ("red button", "green button", "blue button"),
            f"{_PKG}.seen.push_buttons:PushButtons",
        ),
        TaskRef(
            "close_microwave",
            "level1",
            "close microwave",
            ("microwave", "microwave door", "microwave door handle"),
            f"{_PKG}.unseen.close_microwave:CloseMicrowave",
        ),
    )
}


def get_task(name: str) -> TaskRef:
    try:
        return TASKS[name]
    except KeyError:
        raise KeyError(f"unknown task '{name}'; available: {', '.join(sorted(TASKS))}") from None
