"""A SAPIEN task from another package, taken the way a user takes it: a plugin package written in a
temporary folder, pip-installed beside this environment, listed by xicm-plugins and evaluated
by xicm-eval with policy=oracle (the task's own scripted solution)."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
from plugin_install import install_beside

pytestmark = [pytest.mark.slow, pytest.mark.pip, pytest.mark.subprocess]

BIN = Path(sys.executable).parent

PYPROJECT = """\
[build-system]
requires = ["setuptools>=61"]
build-backend = "setuptools.build_meta"

[project]
name = "xicm-reach-marker"
version = "0.1.0"
dependencies = ["xicm"]

[project.entry-points.xicm]
reach_marker = "xicm_reach_marker"

[tool.setuptools]
packages = ["xicm_reach_marker"]
"""

PLUGIN = """\
from xicm.core.contracts.hookspecs import hookimpl

from xicm_reach_marker.task import ReachAboveMarker


@hookimpl
def register_tasks(register):
    register("reach_above_marker", ReachAboveMarker, simulator="sapien")
"""

TASK = '''\
"""reach_above_marker (unseen, level 1).

Task description:
    A flat red marker lies on the table. The robot holds its open gripper 5 cm above it.

Randomisations:
    - marker centre x in [0.05, 0.30] m, y in [-0.20, 0.20] m.

Success conditions:
    The TCP is within 2 cm of the point 5 cm above the marker's centre.
"""

import numpy as np
import sapien

from xicm.plugins.simulators.sapien.objects import add_box
from xicm.plugins.simulators.sapien.scene import TABLE_TOP_Z
from xicm.plugins.simulators.sapien.task_base import Task


class ReachAboveMarker(Task):
    name = "reach_above_marker"
    split = "level1"
    instruction = "reach above the red marker"
    object_names = ("red marker",)

    def load(self):
        """Nothing to build before the marker's place is known; see initialise()."""

    def initialise(self, rng, sample_variation):
        builder = self.world.scene.create_actor_builder()
        add_box(builder, [0.03, 0.03, 0.002], color="red")
        centre = [rng.uniform(0.05, 0.30), rng.uniform(-0.20, 0.20), TABLE_TOP_Z + 0.002]
        self.marker = self.objects.actor(builder, "red marker", kind="static", pose=sapien.Pose(centre))

    def hover_point(self):
        return np.asarray(self.marker.pose.p) + [0.0, 0.0, 0.05]

    def evaluate(self):
        return bool(np.linalg.norm(np.asarray(self.world.robot.tcp_pose().p) - self.hover_point()) < 0.02)

    def demonstration(self):
        yield self.key(self.hover_point())
'''


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """The plugin package written to a temporary folder and pip-installed into another one, which
    goes first on PYTHONPATH (nothing is installed into the environment itself)."""
    source = tmp_path_factory.mktemp("xicm-reach-marker")
    (source / "pyproject.toml").write_text(PYPROJECT)
    (source / "xicm_reach_marker").mkdir()
    (source / "xicm_reach_marker" / "__init__.py").write_text(PLUGIN)
    (source / "xicm_reach_marker" / "task.py").write_text(TASK)
    return install_beside(source, tmp_path_factory.mktemp("site"))


def test_xicm_plugins_lists_the_task_of_the_installed_package(installed):
    out = subprocess.run([str(BIN / "xicm-plugins")], capture_output=True, text=True, env=installed, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "reach_marker 0.1.0: register_tasks" in out.stdout
    tasks = next(line for line in out.stdout.splitlines() if line.startswith("task: "))
    assert "reach_above_marker" in tasks.split(": ", 1)[1].split(", ") and "open_drawer" in tasks


def test_the_oracle_solves_every_episode_of_the_third_party_task(installed, tmp_path):
    out_dir = tmp_path / "run"
    out = subprocess.run(
        [str(BIN / "xicm-eval"), "policy=oracle", "benchmark.tasks=[reach_above_marker]", "seeds=[0,1]", "episodes=2",
         f"paths.data={tmp_path}/nothing", f"hydra.run.dir={out_dir}", "progress=false"],
        capture_output=True, text=True, env=installed, timeout=600, cwd=tmp_path,
    )
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-3000:]
    rows = [json.loads(line) for line in (out_dir / "episodes.jsonl").read_text().splitlines()]
    assert [(r["task"], r["seed"], r["episode"], r["success"], r["steps"]) for r in rows] == [
        ("reach_above_marker", s, e, True, 1) for s in (0, 1) for e in (0, 1)
    ]
    assert json.loads((out_dir / "run.json").read_text())["splits"] == {"reach_above_marker": "level1"}
    assert "| reach_above_marker | level1 | 100.0 |" in out.stdout
