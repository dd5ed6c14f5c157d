"""The SAPIEN tasks: `seen/<name>.py` and `unseen/<name>.py`, one Task subclass each.

A task's class attributes (name, split, instruction, object_names) are the only record of
those facts. Task modules import sapien, so the register_tasks hook registers each module by
its file name as a `LazyTask`, which imports the class only when it is first used (its facts
read, or the simulator loading it): building the registry stays free of sapien.
"""

from __future__ import annotations

import functools
import importlib
import pkgutil


class LazyTask:
    """Stands in for the task class of one module: the same facts, and calling it builds the task."""

    def __init__(self, module: str):
        self.module = module
        self.name = module.rsplit(".", 1)[1]

    @functools.cached_property
    def task_class(self) -> type:
        from ..task_base import Task

        module = importlib.import_module(self.module)
        for obj in vars(module).values():
            if isinstance(obj, type) and issubclass(obj, Task) and vars(obj).get("name") == self.name:
                return obj
        raise LookupError(f"{self.module} defines no Task subclass with name = '{self.name}'")

    split = property(lambda self: self.task_class.split)
    instruction = property(lambda self: self.task_class.instruction)
    object_names = property(lambda self: self.task_class.object_names)
    max_control_steps = property(lambda self: getattr(self.task_class, "max_control_steps", None))
    phrasings = property(lambda self: self.task_class.phrasings)

    def __call__(self, *args, **kwargs):
        return self.task_class(*args, **kwargs)

    def __repr__(self) -> str:
        return f"LazyTask({self.module!r})"


def builtin_tasks() -> dict[str, LazyTask]:
    """Every task module of seen/ and unseen/, by task name; none is imported."""
    found = {}
    for split_dir in ("seen", "unseen"):
        package = importlib.import_module(f"{__name__}.{split_dir}")
        for module_info in pkgutil.iter_modules(package.__path__):
            found[module_info.name] = LazyTask(f"{package.__name__}.{module_info.name}")
    return dict(sorted(found.items()))
