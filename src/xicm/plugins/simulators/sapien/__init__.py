"""SAPIEN simulator plugin: AGNOSTOS-style tabletop tasks with a Franka Panda.

Importing this module and building the registry are cheap: sapien is imported by the
factory and by a task's module, which is loaded on the task's first use (tasks.LazyTask).
"""

from xicm.core.contracts.hookspecs import hookimpl

from .options import REPLACED, SapienOptions, check_rates
from .tasks import builtin_tasks


def create_simulator(options: SapienOptions, *, tasks):
    """Build a SapienSimulator (imports sapien) with the tasks Registry.create_simulator hands over."""
    from .simulator import SapienSimulator

    return SapienSimulator(options, tasks=tasks)


@hookimpl
def register_simulators(register):
    register("sapien", create_simulator, options=SapienOptions, check=check_rates, replaced=REPLACED)


@hookimpl
def register_tasks(register):
    for name, task in builtin_tasks().items():
        register(name, task, simulator="sapien")
