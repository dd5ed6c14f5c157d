"""collect(): scripted demos -> pool file, resumable. Uses a fake simulator defined here."""

from pathlib import Path

import numpy as np
import pytest

from xicm.core.text import encoding
from xicm.core.execution.collect import collect
from xicm.core.results.dataset import DemoWriter, load_pool
from xicm.core.contracts.interfaces import Simulator
from xicm.core.contracts.types import CameraFrame, KeyAction, Observation, StepOutcome, TaskInfo, Trajectory
from xicm.plugins.detectors.oracle import OracleDetector

WS = ((-0.3, -0.5, 0.6), (0.7, 0.5, 1.6))
K = np.array([[50.0, 0.0, 16.0], [0.0, 50.0, 12.0], [0.0, 0.0, 1.0]])


class FakeSimulator(Simulator):
    """A fake simulator for tests: a camera at the origin looking down +z sees two square
    patches (the 'cube' moves with the episode); 'hidden' is never visible. The scripted
    demonstration fails on the episodes in `fail`, raises on those in `crash`."""

    workspace = WS

    def __init__(self, fail=(), crash=(), interrupt=()):
        self.fail, self.crash, self.interrupt = set(fail), set(crash), set(interrupt)
        self.resets: list[tuple[str, int, int]] = []
        self.current = None

    def task_names(self):
        return ["fake_push", "fake_lift"]

    def task_info(self, task):
        return TaskInfo(task, "seen", f"{task} it", ("cube", "hidden", "target"))

    def _obs(self, last=False):
        task, seed, episode = self.current
        depth = np.zeros((24, 32), np.float32)
        seg = np.zeros((24, 32), np.int32)
        u = 4 + episode % 10
        depth[10:13, u - 1 : u + 2] = 1.0
        seg[10:13, u - 1 : u + 2] = 1  # cube, centre pixel (u, 11)
        depth[3:6, 25:28] = 1.2
        seg[3:6, 25:28] = 3  # target, centre pixel (26, 4)
        rgb = np.full((24, 32, 3), 255 if last else episode, np.uint8)
        cam = CameraFrame(rgb=rgb, depth=depth, segmentation=seg, intrinsic=K, cam_to_world=np.eye(4))
        return Observation(
            instruction=f"{task} it",
            cameras={"front": cam},
            segment_names={1: "cube", 2: "hidden", 3: "target"},
            object_names=["target", "hidden", "cube"],  # prompt order, not alphabetical
            gripper=KeyAction((0.0, 0.0, 1.0), (1.0, 0.0, 0.0, 0.0), True),
            joint_positions=np.zeros(9),
        )

    def reset(self, task, seed, episode):
        if episode in self.interrupt:
            raise KeyboardInterrupt
        self.resets.append((task, seed, episode))
        self.current = (task, seed, episode)
        return self._obs()

    def observe(self, cameras=None):
        return self._obs(last=True)

    def execute(self, action):
        return StepOutcome(ok=True, success=False)

    def is_success(self):
        return False

    def demonstrate(self):
        episode = self.current[2]
        if episode in self.crash:
            raise RuntimeError("physics exploded")
        T = 20
        vel = np.ones((T, 9))
        grip = np.arange(T) < 10
        poses = np.zeros((T, 7))
        poses[:, 0] = np.linspace(0.0, 0.2, T) + 0.01 * episode
        poses[:, 2] = 1.0
        poses[:, 3] = 1.0
        return Trajectory(np.zeros((T, 9)), vel, grip, poses, success=episode not in self.fail)


def test_collect_writes_successful_demos(tmp_path):
    path = tmp_path / "pool.h5"
    sim = FakeSimulator(fail={1, 3})
    counts = collect(sim, OracleDetector(), ["fake_push", "fake_lift"], 3, seed=7, out_path=path, progress=False)
    assert counts == {"fake_push": (3, 5), "fake_lift": (3, 5)}
    pool = load_pool(path, with_trajectories=True)
    assert [d.demo_id for d in pool] == [
        "fake_lift/s7/e0000", "fake_lift/s7/e0002", "fake_lift/s7/e0004",
        "fake_push/s7/e0000", "fake_push/s7/e0002", "fake_push/s7/e0004",
    ]  # fmt: skip
    d = pool[1]
    assert d.instruction == "fake_lift it" and d.seed == 7 and d.episode == 2
    assert list(d.objects) == ["target", "cube"]  # prompt order; the unseen object is left out
    np.testing.assert_allclose(d.objects["cube"], ((6 - 16) / 50, (11 - 12) / 50, 1.0), atol=1e-6)
    np.testing.assert_allclose(d.objects["target"], ((26 - 16) / 50 * 1.2, (4 - 12) / 50 * 1.2, 1.2), atol=1e-6)
    assert d.first_rgb[0, 0, 0] == 2 and d.last_rgb[0, 0, 0] == 255 and d.first_depth.shape == (24, 32)
    want = encoding.key_actions_from_trajectory(d.trajectory)
    assert len(d.key_actions) == len(want) == 2
    assert encoding.format_actions(d.key_actions, WS) == encoding.format_actions(want, WS)
    with DemoWriter(path, WS) as w:
        log = w.attempts()
    assert log[("fake_push", 7, 1)] == (False, False, "the scripted demonstration did not succeed")
    assert log[("fake_push", 7, 0)] == (True, False, "not detected: hidden")


def test_resume_skips_done_and_failed_episodes(tmp_path):
    path = tmp_path / "pool.h5"
    first = FakeSimulator(fail={1}, interrupt={3})
    with pytest.raises(KeyboardInterrupt):
        collect(first, OracleDetector(), ["fake_push"], 4, seed=0, out_path=path, progress=False)
    assert [e for _, _, e in first.resets] == [0, 1, 2]

    again = FakeSimulator(fail={1})
    counts = collect(again, OracleDetector(), ["fake_push"], 4, seed=0, out_path=path, progress=False)
    assert counts == {"fake_push": (4, 5)}
    assert [e for _, _, e in again.resets] == [3, 4]  # 0, 2 written and 1 failed before: not re-run

    third = FakeSimulator()
    assert collect(third, OracleDetector(), ["fake_push"], 4, seed=0, out_path=path, progress=False) == counts
    assert third.resets == []  # a finished collection does nothing
    more = collect(third, OracleDetector(), ["fake_push"], 5, seed=0, out_path=path, progress=False)
    assert more == {"fake_push": (5, 6)} and [e for _, _, e in third.resets] == [5]
    other_seed = collect(third, OracleDetector(), ["fake_push"], 1, seed=1, out_path=path, progress=False)
    assert other_seed == {"fake_push": (1, 1)} and third.resets[-1] == ("fake_push", 1, 0)


def test_attempt_cap_and_errors_retried_on_resume(tmp_path, caplog):
    path = tmp_path / "pool.h5"
    sim = FakeSimulator(fail={0, 2}, crash={1, 3})
    counts = collect(sim, OracleDetector(), ["fake_push"], 2, seed=0, out_path=path, max_attempts_factor=2, progress=False)
    assert counts == {"fake_push": (0, 4)}
    assert "physics exploded" in caplog.text
    with DemoWriter(path, WS) as w:
        log = w.attempts()
    assert log[("fake_push", 0, 1)] == (False, True, "RuntimeError: physics exploded")
    fixed = FakeSimulator(fail={0, 2})
    counts = collect(fixed, OracleDetector(), ["fake_push"], 2, seed=0, out_path=path, max_attempts_factor=2, progress=False)
    assert counts == {"fake_push": (2, 4)}
    assert [e for _, _, e in fixed.resets] == [1, 3]  # only the crashed episodes are tried again


def test_progress_bar(tmp_path, capsys):
    counts = collect(FakeSimulator(), OracleDetector(), ["fake_push"], 2, seed=0, out_path=tmp_path / "p.h5", progress=True)
    assert counts == {"fake_push": (2, 2)}
    assert "collect" in capsys.readouterr().err


# ------------------------------------------------------------------ out-of-order results
def _file_contents(path):
    with DemoWriter(path, WS) as w:
        log = w.attempts()
    return sorted(d.demo_id for d in load_pool(path)), log


def test_results_out_of_order_are_committed_as_a_sequential_run_would(tmp_path):
    """Worker processes finish episodes in any order; the pool must not depend on it."""
    import random
    import time
    from concurrent.futures import ThreadPoolExecutor

    from xicm.core.execution.collect import attempt_episode
    from xicm.core.execution.collect_walk import EpisodeWalk

    fail, crash, tasks = {1, 4, 5}, {2}, ["fake_push", "fake_lift"]
    sequential = tmp_path / "sequential.h5"
    counts = collect(
        FakeSimulator(fail, crash), OracleDetector(), tasks, 3, 0, sequential, max_attempts_factor=3, progress=False
    )
    assert counts == {"fake_push": (3, 7), "fake_lift": (3, 7)}
    rng = random.Random(0)
    started = []

    def attempt(task, episode):
        started.append((task, episode))
        time.sleep(rng.uniform(0.0, 0.02))  # finish in a shuffled order
        return attempt_episode(FakeSimulator(fail, crash), OracleDetector(), task, 0, episode)

    parallel = tmp_path / "parallel.h5"
    with ThreadPoolExecutor(4) as pool:
        walk = EpisodeWalk(tasks, 3, seed=0, max_attempts_factor=3, in_flight=4)
        assert walk.run(lambda t, e: pool.submit(attempt, t, e), parallel, WS, progress=False) == counts
    assert _file_contents(parallel) == _file_contents(sequential)
    assert sorted(started) == sorted({(t, e) for t in tasks for e in range(7)})  # no simulation wasted


# ------------------------------------------------------------------ real simulator
@pytest.fixture(scope="module")
def sapien_pool(tmp_path_factory):
    from xicm.core.assembly.plugins import get_registry

    sim = get_registry().create_simulator({"name": "sapien"})
    path = tmp_path_factory.mktemp("pool") / "pool.h5"
    try:
        counts = collect(sim, OracleDetector(), ["open_drawer"], 2, seed=0, out_path=path, progress=False)
        sim.reset("open_drawer", 0, 0)
        truth = sim.object_positions()
    finally:
        sim.close()
    return path, counts, truth


def test_collect_with_the_sapien_simulator(sapien_pool):
    path, counts, truth = sapien_pool
    ok, attempts = counts["open_drawer"]
    assert ok == 2 and attempts <= 4
    pool = load_pool(path, with_trajectories=True)
    assert len(pool) == 2 and all(d.demo_id.startswith("open_drawer/s0/e") for d in pool)
    for d in pool:
        assert d.instruction.startswith("open the") and d.key_actions
        assert d.first_rgb.dtype == np.uint8 and d.first_rgb.ndim == 3 and d.first_depth.shape == d.first_rgb.shape[:2]
        assert not np.array_equal(d.first_rgb, d.last_rgb)  # the drawer moved
        assert len(d.trajectory.ee_poses) > len(d.key_actions)
        assert d.key_actions[-1].position == pytest.approx(tuple(d.trajectory.ee_poses[-1, :3]), abs=1e-6)
    first = next(d for d in pool if d.episode == 0)
    assert first.objects, "the oracle detector found no task object"
    for name, xyz in first.objects.items():  # visible-surface centre vs. the object's true centre
        assert np.linalg.norm(np.subtract(xyz, truth[name])) < 0.03, name


@pytest.mark.slow
@pytest.mark.subprocess
def test_parallel_collection_killed_then_resumed(tmp_path):
    """xicm-collect over 2 worker processes: kill -9 mid-run, no orphan workers, nothing
    half-written, and the re-run completes the pool as an uninterrupted run would."""
    import os
    import signal
    import subprocess
    import sys
    import time

    pool = tmp_path / "pool.h5"
    cmd = [
        str(Path(sys.executable).parent / "xicm-collect"),
        "benchmark=smoke",
        "collect.demos_per_task=12",
        "collect.workers=2",
        f"pool_path={pool}",
        f"hydra.run.dir={tmp_path}/out",
    ]
    env = dict(os.environ, WANDB_MODE="disabled")
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True)
    workers: set[int] = set()
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and proc.poll() is None:
        workers |= _children(proc.pid)
        if len(workers) >= 2 and pool.exists() and pool.stat().st_size > 200_000:
            break
        time.sleep(0.2)
    assert proc.poll() is None, "the collection ended before it could be killed: " + proc.stderr.read()[-2000:]
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    deadline = time.monotonic() + 30
    while any(Path(f"/proc/{pid}").exists() for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not any(Path(f"/proc/{pid}").exists() for pid in workers), "orphaned workers still run"

    done = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "| open_drawer | 12 | 12 | 100.0 |" in done.stdout and "| push_buttons | 12 | 12 | 100.0 |" in done.stdout
    ids = sorted(d.demo_id for d in load_pool(pool))
    assert ids == sorted(f"{t}/s10000/e{e:04d}" for t in ("open_drawer", "push_buttons") for e in range(12))
    import h5py

    with h5py.File(pool, "r") as f:
        assert len(f["_incomplete"]) == 0


def _children(pid: int) -> set[int]:
    """Worker processes of `pid` (Linux /proc)."""
    found = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            cmdline = (stat.parent / "cmdline").read_bytes()
            if b"spawn_main" in cmdline:
                found.add(int(stat.parent.name))
    return found
