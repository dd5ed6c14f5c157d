"""xicm-kinematic: a minimal second simulator for the tests, registered as a third-party plugin
(entry point `xicm` -> this module, through the dist-info folder beside it: no pip install).

A point TCP with a gripper, one cube and a target zone, drawn with numpy; tasks
push_cube_to_zone and pick_cube_to_zone (tasks.py). Cheap to build, so every track's test can
run on it: the contract check, xicm-eval (and envs=N), the Gymnasium env, xicm-export's
recording and xicm-serve-policy.
"""

from dataclasses import dataclass, field
from typing import Any, List

from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.schema import above, one_of, rule

from .render import CAMERAS
from .simulator import STEP_MODES


def _size(v: Any) -> bool:
    sides = [v] if isinstance(v, int) else list(v) if isinstance(v, list) and len(v) == 2 else []
    return bool(sides) and all(isinstance(s, int) and not isinstance(s, bool) and 8 <= s <= 512 for s in sides)


@dataclass
class KinematicOptions:
    image_size: Any = field(default=64, metadata=rule(_size, "an integer or [height, width], each 8..512"))
    cameras: List[str] = field(default_factory=lambda: list(CAMERAS),
                               metadata=rule(lambda v: len(v) > 0 and set(v) <= set(CAMERAS), f"a non-empty list of {', '.join(CAMERAS)}"))
    control_mode: str = field(default="ee_delta", metadata=one_of(*STEP_MODES))
    control_hz: float = field(default=10.0, metadata=above(0))
    lin_speed: float = field(default=0.5, metadata=above(0))
    render: bool = True


def create_simulator(options: KinematicOptions, *, tasks):
    """The registry hands a plugin with a schema one instance of it (docs/plugin-authors.md)."""
    from dataclasses import asdict

    from .simulator import KinematicSimulator

    return KinematicSimulator(**asdict(options), tasks=tasks)


@hookimpl
def register_simulators(register):
    register("kinematic", create_simulator, options=KinematicOptions)


@hookimpl
def register_tasks(register):
    from .tasks import TASKS

    for name, task in TASKS.items():
        register(name, task, simulator="kinematic")
