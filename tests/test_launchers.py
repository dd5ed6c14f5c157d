"""Hydra launchers for config-level parallelism (xicm[scale]): joblib runs the jobs of a
multirun in parallel worker processes, submitit hands them to SLURM (or local processes)."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
from hydra import compose, initialize_config_module

from xicm.core.results.run_dir import FOLDER_NAME_LIMIT, short_name

BIN = Path(sys.executable).parent


def _run(tool, *args, cwd):
    out = subprocess.run([str(BIN / tool), *args], capture_output=True, text=True, cwd=cwd, timeout=900)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-4000:]
    return out


@pytest.mark.parametrize("launcher, target", [("submitit_slurm", "SlurmLauncher"), ("submitit_local", "LocalLauncher"), ("joblib", "JoblibLauncher")])
def test_launcher_configs_compose(launcher, target):
    pytest.importorskip("hydra_plugins.hydra_joblib_launcher")
    pytest.importorskip("hydra_plugins.hydra_submitit_launcher")
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        cfg = compose("config", overrides=[f"hydra/launcher={launcher}"], return_hydra_config=True)
    assert cfg.hydra.launcher._target_.endswith(target)



def test_the_slurm_overrides_of_docs_cluster_compose():
    """The command in docs/guides/clusters.md "SLURM (submitit)" (SLURM itself cannot run here)."""
    pytest.importorskip("hydra_plugins.hydra_submitit_launcher")
    overrides = ["hydra/launcher=submitit_slurm", "hydra.launcher.partition=cpu", "hydra.launcher.timeout_min=600",
                 "hydra.launcher.cpus_per_task=4", "hydra.launcher.mem_gb=16", "hydra.launcher.array_parallelism=32",
                 'hydra.launcher.setup=["source /abs/xicm/.venv/bin/activate","export XICM_DATA=/shared/data"]',
                 "hydra.launcher.max_num_timeout=3", "+hydra.launcher.additional_parameters={mail-type:END}",
                 "benchmark=agnostos"]
    doc = (Path(__file__).parents[1] / "docs" / "guides" / "clusters.md").read_text()
    assert all(o.split("=")[0] in doc for o in overrides)
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        launcher = compose("config", overrides=overrides, return_hydra_config=True).hydra.launcher
    assert launcher.setup == ["source /abs/xicm/.venv/bin/activate", "export XICM_DATA=/shared/data"]
    assert launcher.additional_parameters == {"mail-type": "END"} and launcher.submitit_folder == "multirun/agnostos/.submitit/%j"

@pytest.mark.slow
@pytest.mark.subprocess
def test_joblib_multirun_runs_two_jobs_and_the_report_reads_them(tmp_path):
    pytest.importorskip("hydra_plugins.hydra_joblib_launcher")
    # A long extra key makes each job's folder name longer than xicm_dirname's limit: the names
    # are then cut and hashed, in the launcher's worker processes, and must still differ.
    long_note = "joblib-" + "x" * 130
    out = _run(
        "xicm-eval", "-m", "hydra/launcher=joblib", "hydra.launcher.n_jobs=2",
        "policy=oracle", "benchmark.tasks=[push_buttons]", "episodes=1", "seeds=[0],[1]", f"+note={long_note}",
        f"paths.data={tmp_path}/nothing", "hydra.sweep.dir=sweep", "progress=false", "tracking.mode=disabled",
        cwd=tmp_path,
    )
    assert "Joblib.Parallel(n_jobs=2" in out.stdout + out.stderr
    runs = sorted(p.parent for p in (tmp_path / "sweep").rglob("episodes.jsonl"))
    assert len(runs) == 2, runs
    expected = {
        short_name(f"+note={long_note},benchmark.tasks=[push_buttons],episodes=1,policy=oracle,seeds=[{s}]", FOLDER_NAME_LIMIT)
        for s in (0, 1)
    }
    assert {r.name for r in runs} == expected and all(len(n) == 131 for n in expected)
    for run in runs:
        rows = [json.loads(line) for line in (run / "episodes.jsonl").read_text().splitlines()]
        seeds = json.loads((run / "run.json").read_text())["config"]["seeds"]
        assert [(r["task"], r["seed"], r["episode"], r["success"]) for r in rows] == [("push_buttons", seeds[0], 0, True)]
        assert (run / "summary.json").exists()

    report = _run("xicm-report", "sweep", cwd=tmp_path)
    assert report.stdout.count("| push_buttons | seen | 100.0 |") == 2
    assert "## sweep over seeds\n" in report.stdout
    assert len((tmp_path / "sweep" / "sweep.csv").read_text().splitlines()) == 3


def test_list_valued_overrides_are_hashable_sweep_axes(tmp_path):
    """`seeds=[0],[1]` (one launcher job per seed) gives axis values the sweep can sort and plot."""
    from xicm.report.sweep import recorded_overrides, varying

    runs = []
    for seed in (0, 1):
        run = tmp_path / f"s{seed}"
        (run / ".hydra").mkdir(parents=True)
        (run / ".hydra" / "overrides.yaml").write_text(f"- seeds=[{seed}]\n- episodes=1\n- +experiment=smoke\n")
        runs.append(recorded_overrides(run))
    assert runs[0] == {"seeds": "[0]", "episodes": 1, "experiment": "smoke"}
    assert varying(runs) == ["seeds"] and len({r["seeds"] for r in runs}) == 2
