"""The HDF5 demonstration pool (src/xicm/core/results/dataset.py, docs/reference/dataset.md)."""

import os
import signal
import subprocess
import sys
import textwrap
import zlib

import h5py
import numpy as np
import pytest

from xicm.core.text import encoding
from xicm.core.results.dataset import DemoWriter, demo_id, load_pool, pool_info
from xicm.core.contracts.errors import ConfigError
from xicm.core.contracts.types import Demo, KeyAction, Trajectory

WS = ((-0.3, -0.5, 0.6), (0.7, 0.5, 1.6))


def make_demo(task="close_jar", seed=0, episode=0, n_objects=2, T=30, H=12, W=16):
    rng = np.random.default_rng([zlib.crc32(task.encode()), seed, episode])
    quats = rng.normal(size=(T, 4))
    quats /= np.linalg.norm(quats, axis=1, keepdims=True)
    traj = Trajectory(
        joint_positions=rng.normal(size=(T, 9)),
        joint_velocities=rng.normal(size=(T, 9)),
        gripper_open=rng.integers(0, 2, T).astype(bool),
        ee_poses=np.concatenate([rng.uniform(WS[0], WS[1], (T, 3)), quats], axis=1),
        success=True,
    )
    return Demo(
        demo_id=demo_id(task, seed, episode),
        task=task,
        instruction=f"instruction of {task}",
        seed=seed,
        episode=episode,
        # not alphabetical: prompt order must survive
        objects={f"zeta {i}" if i % 2 == 0 else f"alpha {i}": tuple(rng.uniform(WS[0], WS[1])) for i in range(n_objects)},
        key_actions=[
            KeyAction(tuple(p[:3]), tuple(p[3:]), bool(g)) for p, g in zip(traj.ee_poses[::10], traj.gripper_open[::10])
        ],
        first_rgb=rng.integers(0, 256, (H, W, 3), dtype=np.uint8),
        last_rgb=rng.integers(0, 256, (H, W, 3), dtype=np.uint8),
        first_depth=rng.uniform(0.3, 2.0, (H, W)).astype(np.float32),
        last_depth=rng.uniform(0.3, 2.0, (H, W)).astype(np.float32),
        trajectory=traj,
    )


def test_demo_id_convention():
    assert demo_id("open_drawer", 3, 7) == "open_drawer/s3/e0007"
    with pytest.raises(ValueError):
        demo_id("a/b", 0, 0)


def test_round_trip(tmp_path):
    path = tmp_path / "pool.h5"
    written = [make_demo("turn_tap", 0, 1), make_demo("close_jar", 0, 2, n_objects=3), make_demo("close_jar", 0, 0)]
    with DemoWriter(path, WS) as w:
        for d in written:
            assert not w.has(d.demo_id)
            w.write(d)
            assert w.has(d.demo_id)
        with pytest.raises(ValueError, match="already"):
            w.write(written[0])
    loaded = load_pool(path, with_trajectories=True)
    assert [d.demo_id for d in loaded] == ["close_jar/s0/e0000", "close_jar/s0/e0002", "turn_tap/s0/e0001"]
    by_id = {d.demo_id: d for d in written}
    for got in loaded:
        want = by_id[got.demo_id]
        assert (got.task, got.instruction, got.seed, got.episode) == (want.task, want.instruction, want.seed, want.episode)
        assert list(got.objects) == list(want.objects)  # prompt order kept
        np.testing.assert_allclose(list(got.objects.values()), list(want.objects.values()), atol=1e-6)
        assert len(got.key_actions) == len(want.key_actions)
        for a, b in zip(got.key_actions, want.key_actions):
            np.testing.assert_allclose(a.position, b.position, atol=1e-6)
            np.testing.assert_allclose(a.quat_wxyz, b.quat_wxyz, atol=1e-6)
            assert a.gripper_open == b.gripper_open
        # the text the LLM sees is unchanged by storage
        assert encoding.format_actions(got.key_actions, WS) == encoding.format_actions(want.key_actions, WS)
        for name in ("first_rgb", "last_rgb"):
            np.testing.assert_array_equal(getattr(got, name), getattr(want, name))
        for name in ("first_depth", "last_depth"):
            np.testing.assert_allclose(getattr(got, name), getattr(want, name))
        t, u = got.trajectory, want.trajectory
        np.testing.assert_allclose(t.joint_positions, u.joint_positions, atol=1e-6)
        np.testing.assert_allclose(t.joint_velocities, u.joint_velocities, atol=1e-6)
        np.testing.assert_array_equal(t.gripper_open, u.gripper_open)
        np.testing.assert_allclose(t.ee_poses, u.ee_poses, atol=1e-6)

    light = load_pool(path, tasks=["turn_tap"], with_images=False)
    assert [d.demo_id for d in light] == ["turn_tap/s0/e0001"]
    assert light[0].first_rgb is None and light[0].first_depth is None and light[0].trajectory is None
    assert load_pool(path, tasks=["nothing"]) == []
    info = pool_info(path)
    assert info["format_version"] == 1 and info["workspace"] == WS
    assert info["demos"] == {"close_jar": 2, "turn_tap": 1}


def test_readable_with_plain_h5py(tmp_path):
    path = tmp_path / "pool.h5"
    d = make_demo("stack_blocks", 2, 5)
    with DemoWriter(path, WS) as w:
        w.write(d)
    with h5py.File(path, "r") as f:  # only what docs/reference/dataset.md describes
        assert f.attrs["format_version"] == 1
        np.testing.assert_allclose(f.attrs["workspace_low"], WS[0])
        np.testing.assert_allclose(f.attrs["workspace_high"], WS[1])
        assert "xicm" in f.attrs["created_by"]
        g = f["demos/stack_blocks/s2/e0005"]
        assert g.attrs["task"] == "stack_blocks" and g.attrs["instruction"] == d.instruction
        assert g.attrs["seed"] == 2 and g.attrs["episode"] == 5 and g.attrs["demo_id"] == d.demo_id
        assert list(g.attrs["object_names"]) == list(d.objects)
        assert g["objects_xyz"].shape == (2, 3) and g["objects_xyz"].dtype == np.float32
        n = len(d.key_actions)
        assert g["key_actions"].shape == (n, 8) and g["key_actions"].dtype == np.float32
        assert g["key_actions_int"].dtype == np.int16
        assert g["key_actions_int"][()].tolist() == [encoding.action_to_ints(a, WS) for a in d.key_actions]
        assert g["first_rgb"].dtype == np.uint8 and g["first_rgb"].shape == (12, 16, 3)
        assert g["first_depth"].dtype == np.float32 and g["last_depth"].shape == (12, 16)
        assert g["joint_positions"].shape == (30, 9) and g["joint_velocities"].shape == (30, 9)
        assert g["gripper_open"].dtype == np.uint8 and g["ee_poses"].shape == (30, 7)
        assert f["attempts"].shape == (0,)


def test_incomplete_group_ignored_and_cleaned(tmp_path):
    path = tmp_path / "pool.h5"
    with DemoWriter(path, WS) as w:
        w.write(make_demo("close_jar", 0, 0))
        half = w.file.require_group("_incomplete").create_group("deadbeef")  # as a crash leaves it
        half.attrs["target"] = "close_jar/s0/e0001"
        half.create_dataset("objects_xyz", data=np.zeros((1, 3), np.float32))
    assert [d.demo_id for d in load_pool(path)] == ["close_jar/s0/e0000"]
    with DemoWriter(path, WS) as w:
        assert "_incomplete" not in w.file
        assert not w.has("close_jar/s0/e0001")


def test_killed_writer_leaves_no_half_demo(tmp_path):
    """A writer killed with SIGKILL in the middle of a demo: the file stays readable."""
    path = tmp_path / "pool.h5"
    script = textwrap.dedent(
        f"""
        import os, signal, sys
        sys.path.insert(0, {os.path.dirname(__file__)!r})
        import numpy as np
        from test_dataset import make_demo, WS
        from xicm.core.results import dataset
        real_fill = dataset._fill_group
        def dying_fill(g, demo, ws):
            if demo.episode == 1:
                g.create_dataset("objects_xyz", data=np.zeros((2, 3), np.float32))
                g.file.flush()
                os.kill(os.getpid(), signal.SIGKILL)
            real_fill(g, demo, ws)
        dataset._fill_group = dying_fill
        with dataset.DemoWriter({str(path)!r}, WS) as w:
            w.write(make_demo("close_jar", 0, 0))
            w.log_attempt("close_jar", 0, 0, True)
            w.write(make_demo("close_jar", 0, 1))
        """
    )
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert proc.returncode == -signal.SIGKILL, proc.stderr
    assert [d.demo_id for d in load_pool(path)] == ["close_jar/s0/e0000"]
    with DemoWriter(path, WS) as w:
        assert w.demo_ids() == ["close_jar/s0/e0000"]
        assert w.attempts() == {("close_jar", 0, 0): (True, False, "")}
        w.write(make_demo("close_jar", 0, 1))  # the episode can be written again
    assert len(load_pool(path)) == 2


def test_attempt_log(tmp_path):
    path = tmp_path / "pool.h5"
    with DemoWriter(path, WS) as w:
        w.log_attempt("turn_tap", 0, 0, False, "demonstrator failed: unreachable")
        w.log_attempt("turn_tap", 0, 1, True)
    with DemoWriter(path, WS) as w:
        assert w.attempts() == {
            ("turn_tap", 0, 0): (False, False, "demonstrator failed: unreachable"),
            ("turn_tap", 0, 1): (True, False, ""),
        }
    with h5py.File(path, "r") as f:
        rows = f["attempts"][()]
        assert [r["episode"] for r in rows] == [0, 1] and [r["success"] for r in rows] == [0, 1]
    assert pool_info(path)["attempts"] == {"turn_tap": 2}


def test_missing_file_and_wrong_workspace(tmp_path):
    with pytest.raises(ConfigError, match=r"no demonstration pool at .*nope\.h5; run `xicm-collect"):
        load_pool(tmp_path / "nope.h5")
    path = tmp_path / "pool.h5"
    with DemoWriter(path, WS) as w:
        w.write(make_demo())
    with pytest.raises(ConfigError, match="workspace"):
        with DemoWriter(path, ((0, 0, 0), (1, 1, 1))):
            pass
    with pytest.raises(ValueError, match="does not follow"):
        with DemoWriter(path, WS) as w:
            bad = make_demo(episode=3)
            bad.demo_id = "close_jar/3"
            w.write(bad)


def test_docs_snippet_reads_a_pool(tmp_path, monkeypatch, capsys):
    """The plain-h5py example in docs/reference/dataset.md runs on a real pool file."""
    import pathlib
    import re

    doc = (pathlib.Path(__file__).parents[1] / "docs" / "reference" / "dataset.md").read_text()
    snippet = re.search(r"```python\n(.*?)```", doc, re.S).group(1)
    with DemoWriter(tmp_path / "pool.h5", WS) as w:
        w.write(make_demo("close_jar", 0, 3))
    monkeypatch.chdir(tmp_path)
    exec(compile(snippet, "DATASET.md", "exec"), {})
    out = capsys.readouterr().out
    assert out.startswith("close_jar/s0/e0003 instruction of close_jar {")


def test_not_a_pool_file(tmp_path):
    junk = tmp_path / "junk.h5"
    junk.write_bytes(b"not hdf5 at all")
    with pytest.raises(ConfigError, match="cannot read the demonstration pool"):
        load_pool(junk)
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f.create_group("demos")
    with pytest.raises(ConfigError, match="not an xicm demonstration pool"):
        pool_info(other)
    with pytest.raises(ConfigError, match="not an xicm demonstration pool"):
        DemoWriter(other, WS).open()
