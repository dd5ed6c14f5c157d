"""The example third-party plugin package (examples/xicm-object-overlap), taken the way a user
takes it: pip-installed from its folder, listed by xicm-plugins, selected on the command line."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
from plugin_install import install_beside

pytestmark = [pytest.mark.slow, pytest.mark.pip, pytest.mark.subprocess]

EXAMPLE = Path(__file__).parents[1] / "examples" / "xicm-object-overlap"
BIN = Path(sys.executable).parent


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """pip-install the example into its own folder; PYTHONPATH puts it beside this environment."""
    return install_beside(EXAMPLE, tmp_path_factory.mktemp("site"))


def test_xicm_plugins_lists_the_installed_plugin_with_its_version(installed):
    out = subprocess.run([str(BIN / "xicm-plugins")], capture_output=True, text=True, env=installed, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "object_overlap 0.1.0: register_retrievers" in out.stdout
    assert "retriever: dynamics, object_overlap, random, similarity" in out.stdout


def test_an_episode_runs_with_the_plugin_selected_from_the_command_line(installed, smoke_pool, tmp_path):
    pool_path, _ = smoke_pool
    out_dir = tmp_path / "run"
    out = subprocess.run(
        [str(BIN / "xicm-eval"), "retriever=object_overlap", "retriever.instruction_weight=0.5", "benchmark=smoke",
         "benchmark.tasks=[close_microwave]", "episodes=1", "policy.k=2", f"pool_path={pool_path}",
         f"hydra.run.dir={out_dir}", "progress=false"],
        capture_output=True, text=True, env=installed, timeout=600, cwd=tmp_path,
    )
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-3000:]
    assert "| close_microwave | level1 |" in out.stdout
    row = json.loads((out_dir / "episodes.jsonl").read_text().splitlines()[0])
    assert len(row["retrieved"]) == 2
    run = json.loads((out_dir / "run.json").read_text())
    assert run["config"]["retriever"] == {"name": "object_overlap", "instruction_weight": 0.5}
    assert {"name": "object_overlap", "version": "0.1.0", "hooks": ["register_retrievers"]} in run["plugins"]


def test_the_retriever_prefers_scenes_that_name_the_same_objects():
    sys.path.insert(0, str(EXAMPLE))
    try:
        from xicm_object_overlap import ObjectOverlapRetriever
    finally:
        sys.path.remove(str(EXAMPLE))
    import numpy as np

    from xicm.core.contracts.types import Demo, Query

    def demo(i, names, instruction):
        return Demo(f"d{i}", "t", instruction, 0, i, {n: (0.0, 0.0, 0.0) for n in names}, [])

    pool = [demo(0, ["red button"], "push the red button"), demo(1, ["top drawer handle"], "open the top drawer"),
            demo(2, ["jar lid", "red jar"], "close the red jar")]
    query = Query("close_microwave", "close microwave", {"microwave door handle": (0.0, 0.0, 0.0)})
    ranked = ObjectOverlapRetriever().select(query, pool, 2, np.random.default_rng(0))
    assert ranked[0][0].demo_id == "d1" and ranked[0][1] > ranked[1][1] >= 0  # "handle" is shared
