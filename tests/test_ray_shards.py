"""Episode-level sharding over Ray actors (shards.backend=ray) against a local run of the same keys.

The slow tests start a local Ray cluster on this machine (2 actors, half a CPU each, no
dashboard) through the real `xicm-eval` console script, and a cluster of two `ray start` nodes
(tests/ray_cluster.py) that loses a node and a driver mid-run."""

import json
import os
import re
import signal
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import pytest
from hydra import compose, initialize_config_module
from omegaconf import OmegaConf

from xicm.core.contracts.errors import XicmError
from xicm.core.results.run_dir import config_fingerprint
from xicm.core.assembly.config_schema import Shards
from xicm.core.execution.episode_runner import shard_options
from xicm.core.execution.ray_shards import RayEpisodeShards
from xicm.serving.ports import free_port

from ray_cluster import RayNodes

BIN = Path(sys.executable).parent
RAY = ["shards.backend=ray", "shards.workers=2", "shards.cpus_per_worker=0.5"]
SAME = ("task", "seed", "episode", "success", "steps", "error_kind")  # what a deterministic policy repeats


def _compose(overrides=()):
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        return compose("config", overrides=list(overrides))


def _eval(*args, cwd, env=None):
    out = subprocess.run([str(BIN / "xicm-eval"), *args], capture_output=True, text=True, cwd=cwd, env=env, timeout=900)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-4000:]
    return out.stdout + out.stderr


def _rows(run: Path) -> list[dict]:
    return [json.loads(line) for line in (run / "episodes.jsonl").read_text().splitlines()]


def _worker_counts(output: str) -> dict[int, int]:
    """{pid: episodes} from the driver's closing line `shards: episodes run per worker: pid P on node IP ID: N, ...`."""
    line = next(l for l in output.splitlines() if "shards: episodes run per worker:" in l)
    return {int(p): int(n) for p, n in re.findall(r"pid (\d+) on node [^:,]+: (\d+)", line)}


def test_ray_is_imported_only_when_a_run_uses_it():
    code = (
        "import sys; from xicm.core.assembly import eval_job; from xicm.core.execution import episode_runner;"
        "episode_runner.shard_options(__import__('omegaconf').OmegaConf.create({'shards': {'backend': 'local', "
        "'workers': 1, 'address': None, 'cpus_per_worker': 1}}));"
        "print('ray' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "False"


def test_settings_are_the_typed_shards_options():  # their bad values: tests/test_config_schema.py
    assert shard_options(_compose()) == Shards("local", 2, None, 1)
    ray = shard_options(_compose(["shards.backend=ray", "shards.workers=3", "shards.address=auto", "shards.cpus_per_worker=0.5"]))
    assert ray == Shards("ray", 3, "auto", 0.5)


def test_sharding_does_not_change_what_a_run_is():
    """A run started locally may be resumed on Ray (and back), and lands in the same sweep folder."""
    assert config_fingerprint(_compose()) == config_fingerprint(_compose(RAY))
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        cfg = compose("config", overrides=RAY, return_hydra_config=True)
    assert cfg.hydra.job.override_dirname == ""  # none of the shards.* overrides names the folder


def test_an_unreachable_cluster_address_fails_at_once():
    ray = pytest.importorskip("ray")
    port = free_port()  # nobody listens there
    with pytest.raises(XicmError, match=rf"cannot reach the Ray cluster at shards.address=127.0.0.1:{port} "):
        RayEpisodeShards(Shards("ray", 1, f"127.0.0.1:{port}", 1.0), {}, {}, [("open_drawer", 0, 0)])
    assert not ray.is_initialized()


@pytest.mark.slow
@pytest.mark.ray
def test_a_worker_that_cannot_build_stops_the_run_with_its_reason_and_the_cluster_is_shut_down():
    ray = pytest.importorskip("ray")
    config = {"simulator": {"name": "no_such_simulator"}, "max_steps": 3}
    with pytest.raises(XicmError, match="a Ray shard worker failed .*unknown simulator 'no_such_simulator'; available: sapien"):
        RayEpisodeShards(Shards("ray", 1, None, 0.5), config, {}, [("open_drawer", 0, 0)])
    assert not ray.is_initialized()


@pytest.mark.slow
@pytest.mark.ray
def test_ray_oracle_run_matches_a_local_run_and_resumes_a_partial_file(tmp_path):
    common = ["policy=oracle", "benchmark=smoke", "episodes=2", f"paths.data={tmp_path}/nothing", "progress=false",
              "tracking.mode=disabled"]
    _eval(*common, "hydra.run.dir=local", cwd=tmp_path)
    local = _rows(tmp_path / "local")
    assert len(local) == 6

    # A killed run: two finished episodes and a torn third line.
    sharded = tmp_path / "sharded"
    sharded.mkdir()
    kept = (tmp_path / "local" / "episodes.jsonl").read_text().splitlines(keepends=True)[:2]
    (sharded / "episodes.jsonl").write_text("".join(kept) + '{"task": "push_butt')
    output = _eval(*common, *RAY, "hydra.run.dir=sharded", cwd=tmp_path)

    lines = (sharded / "episodes.jsonl").read_text().splitlines(keepends=True)
    assert lines[:2] == kept  # the finished episodes were not run again
    rows = _rows(sharded)
    assert [tuple(r[k] for k in SAME) for r in rows] == [tuple(r[k] for k in SAME) for r in local]
    counts = _worker_counts(output)
    assert len(counts) == 2 and sum(counts.values()) == 4 and min(counts.values()) >= 1, output[-2000:]
    summary = json.loads((sharded / "summary.json").read_text())
    assert [t["success"] for t in summary["tasks"]] == [100.0, 100.0, 100.0]

    # Everything done: the same command starts no cluster and writes nothing.
    again = _eval(*common, *RAY, "hydra.run.dir=sharded", cwd=tmp_path)
    assert "shards:" not in again
    assert (sharded / "episodes.jsonl").read_text().splitlines(keepends=True) == lines


@pytest.mark.slow
@pytest.mark.ray
def test_ray_nearest_demo_run_matches_a_local_run(smoke_pool, tmp_path):
    pool_path, _ = smoke_pool
    common = ["llm=nearest_demo", "retriever=random", "policy.k=2", "benchmark=smoke", "episodes=1",
              f"pool_path={pool_path}", "progress=false", "tracking.mode=disabled", f"paths.cache={tmp_path}/cache"]
    _eval(*common, "hydra.run.dir=local", cwd=tmp_path)
    output = _eval(*common, *RAY, "hydra.run.dir=sharded", cwd=tmp_path)
    # Not `responses` beyond the first prompt's: replies after contact can move by one 1-cm bin with
    # the PhysX solver's history (which episodes a process ran before), docs/reference/internals.md "Scale-out".
    fields = SAME + ("retrieved", "prompt_hash")
    local, sharded = _rows(tmp_path / "local"), _rows(tmp_path / "sharded")
    assert len(local) == 3 and all(r["responses"] and r["prompt_hash"] for r in local)
    assert [r["responses"][0] for r in sharded] == [r["responses"][0] for r in local]
    assert [tuple(json.dumps(r[k]) for k in fields) for r in sharded] == [tuple(json.dumps(r[k]) for k in fields) for r in local]
    assert len(_worker_counts(output)) == 2



@pytest.mark.slow
@pytest.mark.ray
def test_a_killed_worker_s_episodes_run_on_the_other_and_losing_the_last_one_stops_the_run(tmp_path, capsys):
    ray = pytest.importorskip("ray")
    cfg = _compose(["policy=oracle", "simulator.cameras=[front]", "simulator.image_size=64", f"paths.data={tmp_path}/x"])
    config = OmegaConf.to_container(cfg)  # unresolved: the run name and tracking keys need a Hydra job
    keys = [("push_buttons", 0, e) for e in range(6)]
    shards = RayEpisodeShards(Shards("ray", 2, None, 0.5), config, {"max_steps": 3}, keys)
    try:
        first = shards(*keys[0])
        doomed = next(i for i, n in enumerate(shards.queued) if n)  # an actor with keys handed out
        ray.kill(shards.actors[doomed])
        results = [first] + [shards(*k) for k in keys[1:]]
        assert [(r.task, r.seed, r.episode) for r in results] == keys
        assert re.search(rf"shards: lost the Ray worker pid {shards.where[doomed]['pid']} .*its [1-9] unfinished "
                         r"episode\(s\) run again on the 1 other worker\(s\)", capsys.readouterr().out)
        assert {r.extra["shard"]["pid"] for r in results[1:]} >= {shards.where[1 - doomed]["pid"]}

        ray.kill(shards.actors[1 - doomed])
        with pytest.raises(XicmError, match="every Ray shard worker was lost"):
            shards("push_buttons", 0, 6)
    finally:
        shards.close()
    assert not ray.is_initialized()

PID_POLICY = '''import os
from xicm.core.contracts.hookspecs import hookimpl
from xicm.plugins.policies.oracle import OraclePolicy

def create(context, **options):
    with open(os.environ["XICM_TEST_PID_FILE"], "a") as f:
        f.write(f"{os.getpid()}\\n")
    return OraclePolicy(context.simulator)

@hookimpl
def register_policies(register):
    register("pid_oracle", create)
'''


@pytest.mark.slow
@pytest.mark.ray
def test_the_ray_driver_builds_no_policy_only_its_workers_do(tmp_path):
    """A throwaway policy plugin notes the pid of every process that builds it."""
    site = tmp_path / "site"
    info = site / "xicm_pid_policy-0.1.dist-info"
    info.mkdir(parents=True)
    (site / "xicm_pid_policy.py").write_text(PID_POLICY)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: xicm_pid_policy\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[xicm]\npid_policy = xicm_pid_policy\n")
    pid_file = tmp_path / "pids.txt"
    env = {**os.environ, "XICM_TEST_PID_FILE": str(pid_file),
           "PYTHONPATH": os.pathsep.join(filter(None, [str(site), os.environ.get("PYTHONPATH")]))}
    args = [str(BIN / "xicm-eval"), "policy.name=pid_oracle", "benchmark=smoke", "episodes=1", "progress=false",
            "tracking.mode=disabled", f"paths.data={tmp_path}/nothing", "hydra.run.dir=run", *RAY]
    driver = subprocess.Popen(args, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    output, _ = driver.communicate(timeout=900)
    assert driver.returncode == 0, output[-3000:]
    built_in = [int(line) for line in pid_file.read_text().split()]
    workers = set(_worker_counts(output))
    assert sorted(built_in) == sorted(workers) and driver.pid not in built_in


SMOKE_TASKS = ("open_drawer", "push_buttons", "close_microwave")
TWO_NODES = ["policy=oracle", "benchmark=smoke", "simulator.cameras=[front]", "simulator.image_size=64",
             "progress=false", "tracking.mode=disabled", "shards.backend=ray", "shards.workers=2",
             "shards.cpus_per_worker=1"]  # one CPU per node: one actor lands on each
SECOND_IP = "127.0.0.2"


def _written_rows(run: Path) -> list[dict]:
    """The complete lines of a run's episodes.jsonl while it is written (or after its driver was killed)."""
    path = run / "episodes.jsonl"
    text = path.read_text() if path.exists() else ""
    return [json.loads(line) for line in text.splitlines(keepends=True) if line.endswith("\n")]


def _wait_rows(run: Path, driver: subprocess.Popen, until, timeout_s: float = 300) -> list[dict]:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        rows = _written_rows(run)
        if until(rows):
            return rows
        assert driver.poll() is None, f"the run ended (code {driver.returncode}) before the moment to kill came"
        time.sleep(0.2)
    raise AssertionError(f"no such moment in {timeout_s} s; rows so far: {len(_written_rows(run))}")


def _each_key_once(rows: list[dict], episodes: int) -> dict:
    """Figures of a finished run; fails on a duplicated or a missing (task, seed, episode)."""
    keys = [(r["task"], r["seed"], r["episode"]) for r in rows]
    duplicates = len(keys) - len(set(keys))
    lost = {(t, 0, e) for t in SMOKE_TASKS for e in range(episodes)} - set(keys)
    assert duplicates == 0 and not lost, (duplicates, lost)
    return {"rows": len(rows), "duplicates": duplicates, "lost": len(lost),
            "per_node": dict(Counter(r["extra"]["shard"]["node_ip"] for r in rows))}


@pytest.mark.slow
@pytest.mark.ray
def test_two_ray_nodes_share_a_run_and_it_survives_losing_a_node_or_its_driver(tmp_path):
    """Rows name their node; the second node SIGKILLed mid-run (raylet, agents, its actor at once);
    the driver SIGKILLed mid-run and the same command run again. Figures: `pytest -s`."""
    nodes = RayNodes()
    figures, worker_pids, drivers = {}, set(), []
    try:
        nodes.head(cpus=1, resources={"xicm_head": 1})
        second = nodes.join(SECOND_IP, cpus=1, resources={"xicm_second": 1})
        common = [*TWO_NODES, f"paths.data={tmp_path}/nothing", f"shards.address={nodes.address}"]

        def start(*args):
            with open(tmp_path / f"{args[-1].split('=')[-1]}.log", "a") as log:
                drivers.append(subprocess.Popen([str(BIN / "xicm-eval"), *common, *args], cwd=tmp_path, env=nodes.env,
                                                stdout=log, stderr=subprocess.STDOUT, start_new_session=True))
            return drivers[-1]

        no_token = {k: v for k, v in nodes.env.items() if not k.startswith("RAY_AUTH_")}
        refused = subprocess.run([str(BIN / "xicm-eval"), *common, "hydra.run.dir=refused"], cwd=tmp_path, env=no_token,
                                 capture_output=True, text=True, timeout=300)
        assert refused.returncode != 0 and re.search(r"xicm: error: cannot join the Ray cluster at .* also needs "
                                                     r"RAY_AUTH_MODE=token and its token", refused.stderr), refused.stderr[-2000:]

        _eval(*common, "episodes=2", "hydra.run.dir=normal", cwd=tmp_path, env=nodes.env)
        figures["normal"] = _each_key_once(rows := _rows(tmp_path / "normal"), 2)
        assert figures["normal"]["per_node"].get(SECOND_IP, 0) >= 1 and len(figures["normal"]["per_node"]) == 2
        worker_pids |= {r["extra"]["shard"]["pid"] for r in rows}

        # Episodes take ~0.3 s once a worker is warm, and rows come in bursts of up to the window (4 x 2):
        # 24 keys leave seconds of run after the first rows.
        driver = start("episodes=8", "hydra.run.dir=resumed")
        _wait_rows(tmp_path / "resumed", driver, until=lambda rows: len(rows) >= 2)
        os.killpg(driver.pid, signal.SIGKILL)
        driver.wait(timeout=30)
        kept = _written_rows(tmp_path / "resumed")
        assert 0 < len(kept) < 24, "the driver was to be killed mid-run"
        _eval(*common, "episodes=8", "hydra.run.dir=resumed", cwd=tmp_path, env=nodes.env)
        rows = _rows(tmp_path / "resumed")
        assert rows[: len(kept)] == kept  # the episodes written before the kill were not run again
        figures["driver_killed"] = {**_each_key_once(rows, 8), "rows_before_kill": len(kept)}
        worker_pids |= {r["extra"]["shard"]["pid"] for r in rows}

        driver = start("episodes=8", "hydra.run.dir=node_lost")
        # 2 of 24 rows written: each actor holds 2 keys while more are queued, so the second node has work.
        _wait_rows(tmp_path / "node_lost", driver, until=lambda rows: len(rows) >= 2)
        nodes.kill(second)
        assert driver.wait(timeout=600) == 0, (tmp_path / "node_lost.log").read_text()[-3000:]
        output = (tmp_path / "node_lost.log").read_text()
        lost_line = re.search(rf"shards: lost the Ray worker pid \d+ on node {SECOND_IP} .* its [1-9]\d* unfinished", output)
        assert lost_line, output[-3000:]
        rows = _rows(tmp_path / "node_lost")
        figures["node_killed"] = {**_each_key_once(rows, 8), "log": lost_line.group(0)}
        worker_pids |= {r["extra"]["shard"]["pid"] for r in rows}
        assert nodes.files_naming_the_token(tmp_path) == []  # the token lives in the environment only
    finally:
        for driver in drivers:
            if driver.poll() is None:  # a failed check left it running
                os.killpg(driver.pid, signal.SIGKILL)
                driver.wait()
        leftovers = nodes.close()
        print(json.dumps(figures, indent=1))
    import psutil

    assert leftovers == [] and not [p for p in worker_pids if psutil.pid_exists(p)], (leftovers, worker_pids)
