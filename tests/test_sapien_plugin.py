"""The SAPIEN plugin: cheap to import and to register, its tasks resolved through the registry."""

import subprocess
import sys

import pytest

from xicm.core.assembly import plugins
from xicm.core.contracts.types import TaskInfo


@pytest.fixture(scope="module")
def registry():
    return plugins.Registry(plugins.make_plugin_manager())


def test_building_the_registry_imports_no_sapien_until_a_task_is_used():
    code = (
        "import sys, xicm.core.assembly.plugins as p; r = p.Registry(p.make_plugin_manager()); "
        "print(len(r.tasks(simulator='sapien')), 'sapien' in sys.modules, end=' '); "
        "r.task_info('open_drawer'); print('sapien' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["41", "False", "True"]


def test_every_builtin_task_is_registered_for_sapien(registry):
    tasks = registry.tasks(simulator="sapien")
    assert list(tasks) == registry.names("task") and len(tasks) == 41
    assert {registry.get("task", name).plugin for name in tasks} == {"sapien"}
    assert registry.tasks(simulator="another") == {}


def test_task_info_comes_from_the_task_class(registry):
    from xicm.plugins.simulators.sapien.tasks.unseen.close_microwave import CloseMicrowave

    info = registry.task_info("close_microwave")
    assert info == TaskInfo(
        "close_microwave", "level1", CloseMicrowave.instruction, CloseMicrowave.object_names,
        CloseMicrowave.max_control_steps, CloseMicrowave.phrasings,
    )
    assert info.max_control_steps == 216 and info.phrasings[:2] == ("close microwave", "shut the microwave")
    assert info.instruction == "close microwave"
    splits = [registry.task_info(name).split for name in registry.tasks(simulator="sapien")]
    assert (splits.count("seen"), splits.count("level1"), splits.count("level2")) == (18, 13, 10)  # AGNOSTOS


def test_each_task_module_is_named_after_its_task_and_titled_with_its_split(registry):
    """The class holds the facts; the file name and docstring title repeat name and split."""
    for name, task in registry.tasks(simulator="sapien").items():
        cls = task.task_class
        module = sys.modules[cls.__module__]
        assert cls.name == name and module.__name__.rsplit(".", 1)[1] == name
        level = "seen" if cls.split == "seen" else f"unseen, level {cls.split[-1]}"
        assert module.__doc__.splitlines()[0] == f"{name} ({level}).", name
        assert module.__name__.split(".")[-2] == level.split(",")[0], name  # tasks/seen/ or tasks/unseen/
        for part in ("Task description:", "Randomisations:", "Success conditions:"):
            assert part in module.__doc__, f"{name}: docstring lacks '{part}'"


def test_the_simulator_loads_only_the_tasks_it_is_given(registry):
    from xicm.plugins.simulators.sapien.options import SapienOptions
    from xicm.plugins.simulators.sapien.simulator import SapienSimulator

    sim = SapienSimulator(SapienOptions(render=False), tasks={"drawer": registry.tasks(simulator="sapien")["open_drawer"]})
    try:
        assert sim.task_names() == ["drawer"] and sim.task_info("drawer").split == "seen"
        sim.reset_state("drawer", 0, 0)
        assert sim.task.instruction == "open the top drawer"
        with pytest.raises(KeyError, match="unknown task 'open_drawer'; available: drawer"):
            sim.reset_state("open_drawer", 0, 0)
    finally:
        sim.close()
