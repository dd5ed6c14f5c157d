"""SAPIEN simulator plugin: AGNOSTOS-style tabletop tasks with a Franka Panda.

Importing this module is cheap: sapien is imported by the factory and by the task modules,
which are loaded only when a simulator is created or a task class is asked for.
"""

from xicm.core.hookspecs import hookimpl

from .options import SapienOptions
from .tasks import TASKS


def create_simulator(**options):
    """Build a SapienSimulator (imports sapien)."""
    from .simulator import SapienSimulator

    return SapienSimulator(**options)


@hookimpl
def register_simulators(register):
    register("sapien", create_simulator, options=SapienOptions)


@hookimpl
def register_tasks(register):
    for name, ref in TASKS.items():
        register(name, ref, simulator="sapien")
