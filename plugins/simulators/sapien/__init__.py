"""SAPIEN simulator plugin: AGNOSTOS-style tabletop tasks with a Franka Panda.

Importing this module and building the registry are cheap: sapien is imported by the
factory and by a task's module, which is loaded on the task's first use (tasks.LazyTask).
"""

from xicm.core.hookspecs import hookimpl

from .options import SapienOptions, check_rates
from .tasks import builtin_tasks


def create_simulator(**options):
    """Build a SapienSimulator (imports sapien); options include tasks= (see Registry.create_simulator)."""
    from .simulator import SapienSimulator

    return SapienSimulator(**options)


@hookimpl
def register_simulators(register):
    register("sapien", create_simulator, options=SapienOptions, check=check_rates)


@hookimpl
def register_tasks(register):
    for name, task in builtin_tasks().items():
        register(name, task, simulator="sapien")
