"""A second simulator proves the Simulator contract (issue 30, item 3): the kinematic test world
(tests/kinematic_sim: a cube, a point gripper, a target zone, pictures drawn with numpy), taken
as a third-party plugin, passes check_simulator and drives every track: xicm-eval (oracle, and
X-ICM over a pool that xicm-collect gathered from it), envs=2, the Gymnasium env, xicm-export's
recording, and xicm-serve-policy with xicm-eval policy=remote."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from kinematic_plugin import kinematic_env, kinematic_registry  # noqa: F401 - a fixture
from serve_wait import wait_for_serving
from test_export import needs_lerobot

from xicm.core.contracts.simulator_check import check_simulator
from xicm.serving.ports import free_port

BIN = Path(sys.executable).parent
TASKS = ["push_cube_to_zone", "pick_cube_to_zone"]
ON_THE_COMMAND_LINE = ["simulator=kinematic", f"benchmark.tasks=[{','.join(TASKS)}]", f"benchmark.pool_tasks=[{','.join(TASKS)}]",
                       "progress=false"]
ROW = ("task", "seed", "episode", "success", "steps", "error_kind")


@pytest.fixture
def kinematic(kinematic_registry):  # noqa: F811 - the fixture imported above
    simulator = kinematic_registry.create_simulator({"name": "kinematic", "image_size": 48})
    yield simulator
    simulator.close()


def xicm(command: str, *overrides: str, cwd: Path, timeout: int = 300) -> subprocess.CompletedProcess:
    out = subprocess.run([str(BIN / command), *ON_THE_COMMAND_LINE, *overrides], capture_output=True, text=True,
                         env=kinematic_env(), cwd=cwd, timeout=timeout)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-3000:]
    return out


def rows(run_dir: Path, keys=ROW) -> list[dict]:
    return [{k: r[k] for k in keys} for r in map(json.loads, (run_dir / "episodes.jsonl").read_text().splitlines())]


def test_check_simulator_passes_on_every_task_and_episode(kinematic):
    for task in TASKS:
        for episode in range(4):
            report = check_simulator(kinematic, task, seed=0, episode=episode)
            assert report["skipped"] == [] and "record_scripted + replay" in report["checked"]
    assert kinematic.control_spec().mode_names() == ["ee_delta", "ee_pos", "key_pose"]


def test_its_pictures_show_the_cube_where_it_is(kinematic):
    """Depth, segmentation and the cameras' intrinsics and poses agree: the oracle detector
    back-projects the cube's pixels onto the cube's top face, from either camera."""
    from xicm.plugins.detectors.oracle import OracleDetector, OracleOptions

    obs = kinematic.reset("pick_cube_to_zone", 0, 1)
    assert obs.cameras["top"].rgb.shape == (48, 48, 3) and set(np.unique(obs.cameras["top"].segmentation)) == {0, 1, 2}
    for camera in ("top", "front"):
        found = OracleDetector(OracleOptions(cameras=[camera])).detect(obs, ["red cube", "green zone"])
        assert np.abs(np.subtract(found["red cube"][:2], kinematic.world.cube[:2])).max() < 0.02, camera
        assert np.abs(np.subtract(found["green zone"][:2], kinematic.world.zone)).max() < 0.02, camera


def test_xicm_eval_oracle_solves_every_episode_with_videos_and_envs_2_gives_the_same_rows(tmp_path):
    common = ["policy=oracle", "seeds=[0,1]", "episodes=2", f"paths.cache={tmp_path}/cache"]
    out = xicm("xicm-eval", *common, "video.enabled=true", "video.every=2", "hydra.run.dir=one", cwd=tmp_path)
    xicm("xicm-eval", *common, "envs=2", "hydra.run.dir=two", cwd=tmp_path)
    one = rows(tmp_path / "one")
    assert [(r["task"], r["seed"], r["episode"], r["success"]) for r in one] == [
        (t, s, e, True) for s in (0, 1) for t in TASKS for e in (0, 1)]
    assert rows(tmp_path / "two") == one
    videos = [r["extra"] for r in rows(tmp_path / "one", ("extra",))]  # one picture per 2 control periods (set_frame_callback)
    assert all(v["video"].endswith("-PASS.mp4") and (tmp_path / "one" / v["video"]).exists() and v["video_frames"] > 3 for v in videos), videos
    assert json.loads((tmp_path / "one" / "run.json").read_text())["splits"] == {"push_cube_to_zone": "seen", "pick_cube_to_zone": "level1"}
    assert "| pick_cube_to_zone | level1 | 100.0 |" in out.stdout


def test_xicm_collect_gathers_a_pool_that_x_icm_evaluates_with(tmp_path, kinematic_registry):  # noqa: F811
    pool = f"pool_path={tmp_path}/pool.h5"
    top_only = ["simulator.cameras=[top]", "simulator.image_size=64"]  # no camera is called front (SAPIEN's default name)
    sim = kinematic_registry.create_simulator({"name": "kinematic", "cameras": ["top"], "image_size": 64})
    collected = xicm("xicm-collect", "collect.demos_per_task=3", "collect.workers=1", pool, *top_only, "hydra.run.dir=collect", cwd=tmp_path)
    assert "| push_cube_to_zone | 3 | 3 | 100.0 |" in collected.stdout and "| pick_cube_to_zone | 3 | 3 | 100.0 |" in collected.stdout
    from xicm.core.results.dataset import load_pool

    first = load_pool(tmp_path / "pool.h5", ["pick_cube_to_zone"], with_images=True)[0]
    sim.reset("pick_cube_to_zone", first.seed, first.episode)  # the same scene, in this process
    np.testing.assert_array_equal(first.first_rgb, sim.observe(["top"]).cameras["top"].rgb)  # the pool stores the first camera
    sim.close()
    xicm("xicm-eval", "policy=xicm", "llm=nearest_demo", "policy.k=2", pool, *top_only, "episodes=2", f"paths.cache={tmp_path}/cache",
         "hydra.run.dir=xicm", cwd=tmp_path)
    done = rows(tmp_path / "xicm", ROW + ("retrieved", "responses"))
    assert [(r["task"], r["episode"]) for r in done] == [(t, e) for t in TASKS for e in (0, 1)]
    for r in done:  # each episode asked the LLM with 2 demos of its own task from the pool and acted on the reply
        assert len(r["retrieved"]) == 2 and all(d.startswith(f"{r['task']}/s10000/") for d in r["retrieved"]) and r["responses"]
        assert r["error_kind"] in (None, "max_steps"), r
    assert any(r["success"] for r in done)


def test_the_gymnasium_env_steps_it_with_spaces_from_its_control_spec(kinematic_registry):  # noqa: F811
    from xicm.vla.gym_env import XicmEnv

    recorder = kinematic_registry.create_simulator({"name": "kinematic", "render": False})
    recorder.reset_state("pick_cube_to_zone", 7, 2)
    recording = recorder.record_scripted()
    for mode in ("ee_delta", "ee_pos"):
        env = XicmEnv("pick_cube_to_zone", simulator="kinematic", control_mode=mode, cameras=["top"], image_size=32)
        try:
            assert env.action_space.shape == (4,) and env.max_control_steps == 200
            assert {k: s.shape for k, s in env.observation_space["state"].items()} == {
                "joint_positions": (3,), "gripper_width": (1,), "gripper_open": (1,)}
            obs, info = env.reset(seed=7, options={"episode": 2})
            assert obs["rgb"]["top"].shape == (32, 32, 3) and info["instruction"] == recording.instruction
            np.testing.assert_array_equal(obs["state"]["joint_positions"], recording.proprio["joint_positions"][0].astype(np.float32))
            for t, action in enumerate(recording.actions[mode]):
                obs, reward, terminated, truncated, info = env.step(action)
                assert "error_kind" not in info and not truncated
                if terminated:
                    break
            release = recording.key_action_steps[4]  # the fifth key action opens the gripper over the zone
            assert terminated and reward == 1.0 and t == release, (mode, t, release)
            env.reset(seed=7, options={"episode": 2})
            far = [1.0, 0, 0, 1] if mode == "ee_pos" else [0.0, 0.0, -0.05, 1]  # beside the box / below the table
            if mode == "ee_delta":
                for _ in range(4):
                    env.step(far)
            _, _, _, _, info = env.step(far)
            assert info["error_kind"] == "unreachable" and "outside the workspace" in info["error_message"]
        finally:
            env.close()
    recorder.close()


def test_its_tasks_register_as_gymnasium_ids_and_a_state_only_env_renders_nothing(kinematic_registry):  # noqa: F811
    """register_envs(simulator) names its tasks; a state-only env (the default cameras front and
    wrist, which this simulator does not have) builds it without cameras."""
    import gymnasium

    from xicm.vla.registration import register_envs

    ids = register_envs("kinematic")
    try:
        assert ids == ["xicm/PickCubeToZone-v0", "xicm/PushCubeToZone-v0"]
        env = gymnasium.make(ids[1], obs_mode="state", control_mode="ee_pos")
        try:
            obs, info = env.reset(seed=0)
            assert set(obs) == {"state"} and info["instruction"] == "push the red cube into the green zone"
            assert env.unwrapped.sim.image_sizes() == {}
        finally:
            env.close()
    finally:
        for env_id in ids:
            gymnasium.registry.pop(env_id, None)


def test_xicm_export_records_its_episodes_through_the_contract(kinematic):
    from xicm.export import features as feats
    from xicm.export.record import record_episode

    staged = record_episode(kinematic, "push_cube_to_zone", 10_000, 0, ["top", "front"])
    arrays, spec = staged.arrays, kinematic.control_spec()
    steps = len(arrays["action.ee_delta"])
    expected = feats.features(kinematic.image_sizes(), spec, use_videos=False)
    checked = [name for name in expected if feats.staged_column(name, spec.control_mode) in arrays]
    assert {"action", "observation.state", "observation.images.top", "observation.images.front"} <= set(checked)
    for name in checked:  # every staged column has its LeRobot feature's shape, one row per control step
        column = arrays[feats.staged_column(name, spec.control_mode)]
        assert column.shape == (steps, *expected[name]["shape"]), (name, column.shape, expected[name]["shape"])
    assert expected["observation.state"]["shape"] == [5] and expected["action"]["shape"] == [4]
    assert arrays["key_action.ends_here"].sum() == 4  # behind the cube, down, push, up: the whole scripted solution


@pytest.mark.slow
@pytest.mark.venv
@needs_lerobot
def test_xicm_export_writes_a_lerobot_dataset_of_it(tmp_path):
    from xicm.lerobot.dataset_writer import read_dataset

    out_dir = tmp_path / "kinematic"
    done = xicm("xicm-export", f"export.tasks=[{','.join(TASKS)}]", "export.demos_per_task=2", "export.workers=1",
                "export.cameras=[top]", f"export.out_dir={out_dir}", "export.repo_id=xicm/kinematic", "hydra.run.dir=export",
                cwd=tmp_path, timeout=600)
    assert "| push_cube_to_zone | 2 | 2 | 100.0 |" in done.stdout and "| pick_cube_to_zone | 2 | 2 | 100.0 |" in done.stdout
    cache = Path(os.environ.get("XICM_CACHE", Path.home() / ".cache" / "xicm"))  # paths.cache's default: the lerobot env
    read_dataset(out_dir, "xicm/kinematic", tmp_path / "loaded.npz", cache)
    data = dict(np.load(tmp_path / "loaded.npz"))
    staged = sorted((tmp_path / "kinematic.staging").rglob("e*.npz"))
    assert int(data["num_episodes"]) == 4 and int(data["num_frames"]) == sum(len(np.load(p)["action.ee_delta"]) for p in staged)
    assert json.loads(str(data["features"]))["action"]["shape"] == [4]


def test_xicm_eval_against_xicm_serve_policy_serving_it(tmp_path):
    port, top_only = free_port(), "simulator.cameras=[top]"  # no camera is called front (SAPIEN's default name)
    server = subprocess.Popen([str(BIN / "xicm-serve-policy"), *ON_THE_COMMAND_LINE, top_only, "policy=oracle", f"serve.port={port}"],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=tmp_path, env=kinematic_env())
    try:
        wait_for_serving(server, "oracle")
        common = [top_only, "seeds=[3]", "episodes=2", f"paths.cache={tmp_path}/cache"]
        xicm("xicm-eval", "policy=remote", f"policy.port={port}", "policy.images={top: observation/image}", *common,
             "hydra.run.dir=served", cwd=tmp_path)
    finally:
        server.terminate()
        server.wait(timeout=30)
    xicm("xicm-eval", "policy=oracle", *common, "hydra.run.dir=local", cwd=tmp_path)
    assert rows(tmp_path / "served") == rows(tmp_path / "local") and all(r["success"] for r in rows(tmp_path / "local"))
