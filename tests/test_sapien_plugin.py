"""The SAPIEN plugin module: cheap to import, registers the simulator and its tasks."""

import subprocess
import sys

import pytest

from xicm.core import plugins


def test_importing_the_plugin_does_not_import_sapien():
    code = (
        "import sys, xicm.plugins.simulators.sapien as p; "
        "from xicm.plugins.simulators.sapien.tasks import TASKS; "
        "print('sapien' in sys.modules, sorted(TASKS))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.startswith("False"), out


def test_registry_has_simulator_and_tasks():
    registry = plugins.Registry(plugins.make_plugin_manager())
    assert "sapien" in registry.names("simulator")
    from xicm.plugins.simulators.sapien.tasks import TASKS

    assert {"open_drawer", "push_buttons", "close_microwave"} <= set(TASKS)
    for name in TASKS:
        reg = registry.get("task", name)
        assert reg.extra == {"simulator": "sapien"}
        assert reg.factory.info().name == name


def test_task_table_matches_the_task_classes():
    pytest.importorskip("sapien")
    from xicm.plugins.simulators.sapien.tasks import TASKS

    for name, ref in TASKS.items():
        cls = ref.load_class()
        assert cls.info() == ref.info(), name
        doc = cls.__module__ and __import__(cls.__module__, fromlist=["_"]).__doc__
        for part in ("Task description:", "Randomisations:", "Success conditions:"):
            assert part in doc, f"{name}: docstring lacks '{part}'"
    splits = {name: ref.split for name, ref in TASKS.items()}
    assert set(splits.values()) <= {"seen", "level1", "level2"}
    assert splits["open_drawer"] == "seen" and splits["close_microwave"] == "level1"


def test_unknown_task_names_the_available_ones():
    from xicm.plugins.simulators.sapien.tasks import TASKS, get_task

    with pytest.raises(KeyError, match="unknown task 'make_tea'; available: ") as err:
        get_task("make_tea")
    assert str(err.value).strip("'\"").endswith("available: " + ", ".join(sorted(TASKS)))
