"""The console scripts end to end, in subprocesses, on the real simulator (slow)."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.slow, pytest.mark.subprocess]

BIN = Path(sys.executable).parent


def _run(tool, *args, cwd):
    out = subprocess.run([str(BIN / tool), *args], capture_output=True, text=True, cwd=cwd, timeout=900)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-4000:]
    return out


@pytest.fixture(scope="module")
def workdir(tmp_path_factory, smoke_pool):
    """A data folder holding the session's smoke pool (conftest.py: what `xicm-collect benchmark=smoke
    collect.demos_per_task=2` writes; test_collect.py runs xicm-collect itself)."""
    import shutil

    work = tmp_path_factory.mktemp("e2e")
    (work / "data" / "pools").mkdir(parents=True)
    shutil.copy(smoke_pool[0], work / "data" / "pools" / "smoke.h5")
    common = [f"paths.data={work}/data", f"paths.cache={work}/cache", "progress=false"]
    return work, common


def test_eval_writes_results_and_resumes(workdir):
    work, common = workdir
    args = ["benchmark=smoke", "episodes=1", "policy.k=2", "hydra.run.dir=run1", *common]
    first = _run("xicm-eval", *args, cwd=work)
    assert "**All**" in first.stdout and "| close_microwave | level1 |" in first.stdout
    run = work / "run1"
    rows = [json.loads(l) for l in (run / "episodes.jsonl").read_text().splitlines()]
    assert [(r["task"], r["seed"], r["episode"]) for r in rows] == [
        ("open_drawer", 0, 0), ("push_buttons", 0, 0), ("close_microwave", 0, 0)
    ]
    assert all(len(r["retrieved"]) == 2 and r["prompt_hash"] and "total" in r["timings"] for r in rows)
    summary = json.loads((run / "summary.json").read_text())
    assert [g["group"] for g in summary["groups"]] == ["Level-1", "Seen", "All"]
    meta = json.loads((run / "run.json").read_text())
    assert any(p["name"] == "nearest_demo" for p in meta["plugins"])
    assert meta["retrieval_features"].startswith("minilm:")  # what the language ranking's features come from

    # same command again: nothing re-run, nothing lost; one more episode extends the run
    _run("xicm-eval", *args, cwd=work)
    assert len((run / "episodes.jsonl").read_text().splitlines()) == 3
    _run("xicm-eval", *[a if a != "episodes=1" else "episodes=2" for a in args], cwd=work)
    assert len((run / "episodes.jsonl").read_text().splitlines()) == 6

    # a different config in the same folder is refused with one sentence
    bad = subprocess.run([str(BIN / "xicm-eval"), *args, "max_steps=3"], capture_output=True, text=True, cwd=work)
    assert bad.returncode == 2 and "holds episodes of a different config" in bad.stderr

    report = _run("xicm-report", str(run), cwd=work)
    assert "| open_drawer | seen |" in report.stdout


def test_a_dead_llm_server_stops_the_run_before_any_episode(workdir):
    from xicm.serving.ports import free_port

    work, common = workdir
    port = free_port()  # nothing listens there
    args = ["benchmark=smoke", "episodes=1", "llm=openai", f"llm.base_url=http://127.0.0.1:{port}/v1", "hydra.run.dir=dead", *common]
    out = subprocess.run([str(BIN / "xicm-eval"), *args], capture_output=True, text=True, cwd=work, timeout=600)
    assert out.returncode == 2 and f"no OpenAI-compatible server answered at http://127.0.0.1:{port}/v1/models" in out.stderr
    assert not (work / "dead" / "episodes.jsonl").exists()


def test_multirun_sweeps_retriever_and_k(workdir):
    work, common = workdir
    _run(
        "xicm-eval", "-m", "retriever=random,language", "policy.k=1,2", "benchmark.tasks=[push_buttons]",
        "episodes=1", "hydra.sweep.dir=sweep", *common, cwd=work,
    )
    jobs = sorted(p.parent.name for p in (work / "sweep").rglob("summary.json"))
    assert len(jobs) == 4, jobs
    assert any("retriever=language" in j and "policy.k=2" in j for j in jobs)


def test_smoke_experiment_then_one_sweep_report(workdir):
    work, common = workdir
    _run("xicm-eval", "-m", "+experiment=smoke", "episodes=1", "hydra.sweep.dir=exp", *common, cwd=work)
    out = _run("xicm-report", "exp", cwd=work)
    assert "## sweep over retriever\n" in out.stdout
    assert (work / "exp" / "sweep.png").exists() and len((work / "exp" / "sweep.csv").read_text().splitlines()) == 3


def test_a_killed_multirun_rerun_finishes_only_what_is_missing(workdir):
    work, common = workdir
    sweep = ["xicm-eval", "-m", "retriever=random,language", "benchmark.tasks=[push_buttons]", "episodes=2",
             "hydra.sweep.dir=resume", *common]
    _run(*sweep, cwd=work)
    jobs = sorted((work / "resume").rglob("episodes.jsonl"))
    assert len(jobs) == 2
    before = [j.read_text() for j in jobs]
    kept = before[0].splitlines(keepends=True)[0]
    jobs[0].write_text(kept)  # as if killed after its first episode
    (jobs[0].parent / "summary.json").unlink()
    _run(*sweep, cwd=work)
    after = [j.read_text() for j in jobs]
    assert after[1] == before[1]  # the finished job ran nothing again (timings would differ)
    lines = after[0].splitlines(keepends=True)
    assert len(lines) == 2 and lines[0] == kept  # the kept episode was not re-run, the missing one was
    assert (jobs[0].parent / "summary.json").exists()


def test_oracle_policy_needs_no_pool_and_solves_the_tasks(tmp_path):
    out = tmp_path / "oracle"
    _run(
        "xicm-eval", "policy=oracle", "benchmark=smoke", "episodes=2", f"paths.data={tmp_path}/nothing",
        f"hydra.run.dir={out}", "progress=false", cwd=tmp_path,
    )
    summary = json.loads((out / "summary.json").read_text())
    assert {r["task"]: r["success"] for r in summary["tasks"]} == {t: 100.0 for t in ("open_drawer", "push_buttons", "close_microwave")}
    assert json.loads((out / "run.json").read_text())["policy"] == "oracle"
    assert not (tmp_path / "nothing").exists()


def test_train_dynamics_then_a_selection_sweep_shares_one_feature_cache(workdir):
    work, common = workdir
    out = _run(
        "xicm-train-dynamics", "pool=smoke", "dynamics_model=tiny", "train.steps=6", "train.checkpoint_every=3",
        "train.heldout_every=0", "tracking.mode=disabled", *common, cwd=work,
    )
    assert "step 6/6" in out.stdout and (work / "data" / "dynamics" / "smoke" / "final" / "unet" / "config.json").exists()
    _run(
        "xicm-eval", "-m", "retriever=dynamics", "policy.k=1,2", "encoder.steps=2", "benchmark.tasks=[close_microwave]",
        "episodes=1", "hydra.sweep.dir=dyn", *common, cwd=work,
    )
    rows = [json.loads(p.read_text()) for p in sorted((work / "dyn").rglob("episodes.jsonl"))]
    assert [len(r["retrieved"]) for r in rows] == [1, 2]
    assert len(list((work / "cache" / "features").glob("dynamics*.npy"))) == 1  # computed once, reused by the second job


@pytest.mark.llama_server
def test_eval_with_llamacpp_runs_the_grammar_and_leaves_no_server(workdir, tmp_path):
    """llm=llamacpp through xicm-eval on a tiny GGUF (tests/tiny_gguf.py): every reply is an
    action list, and the server is gone when the command has exited."""
    import re

    from tiny_gguf import write_tiny_gguf
    from xicm.plugins.llms.action_grammar import ACTIONS_REGEX
    from xicm.plugins.llms.llamacpp_server import llama_server_binary

    work, common = workdir
    model = write_tiny_gguf(tmp_path / "tiny-e2e.gguf")
    args = ["benchmark=smoke", "episodes=1", "policy.k=2", "llm=llamacpp", f"llm.model={model}",
            f"llm.binary={llama_server_binary()}", "llm.chat_template=raw", "llm.threads=1",
            "policy.max_llm_calls=2", "hydra.run.dir=llamacpp", *common]
    _run("xicm-eval", *args, cwd=work)
    rows = [json.loads(l) for l in (work / "llamacpp" / "episodes.jsonl").read_text().splitlines()]
    assert len(rows) == 3 and all(r["responses"] for r in rows)
    assert all(re.fullmatch(ACTIONS_REGEX, reply) for r in rows for reply in r["responses"])
    assert not {r["error_kind"] for r in rows} & {"parse_error", "llm_error", "internal_error"}
    # the engine's speed options say how the run is done: another thread count resumes it, and run.json says so
    _run("xicm-eval", *[{"episodes=1": "episodes=2", "llm.threads=1": "llm.threads=2"}.get(a, a) for a in args], cwd=work)
    assert len((work / "llamacpp" / "episodes.jsonl").read_text().splitlines()) == 6
    meta = json.loads((work / "llamacpp" / "run.json").read_text())
    assert meta["how_on_resume"] == [{"episodes_before": 3, "changed": {"llm.threads": [1, 2]}}]
    assert "llm.threads" not in meta["identity"] and meta["config"]["llm"]["threads"] == 2
    left = subprocess.run(["pgrep", "-f", str(model)], capture_output=True, text=True)
    assert left.stdout.strip() == "", "a llama-server outlived xicm-eval"
