"""xicm-export: bad input stops with one sentence; the key-action columns; a real export of two
seen tasks written and loaded by lerobot's own LeRobotDataset (in its isolated env), whose
loaded actions replay to success in the Gymnasium env in every action space; a partial export
resumes."""

import json
from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_module

from xicm.core.contracts.errors import ConfigError
from xicm.core.contracts.spaces import KEY_POSE_NAMES
from xicm.core.contracts.types import KeyAction
from xicm.export import features as feats
from xicm.export.job import check_export, export_tasks
from xicm.export.record import key_action_columns


def _compose(*overrides):
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        return compose("config", overrides=list(overrides))


@pytest.mark.parametrize(
    "override, sentence",
    [
        ("export.cameras=[front,nose]", "export.cameras must be a non-empty list of distinct names from front,"),
        ("simulator.image_size=0", "simulator.image_size must be an integer from 1 to 4096"),
        ("simulator.image_size=5000", "simulator.image_size must be an integer from 1 to 4096"),
        ("simulator.control_mode=ee_velocity", "simulator.control_mode must be one of ee_delta, ee_pose, joint_pos, joint_delta"),
        ("export.tasks=[close_jar,fly_to_moon]", "unknown task 'fly_to_moon' for simulator 'sapien'; available:"),
        ("export.repo_id=nameonly", "export.repo_id must be 'owner/name'"),
        ("export.frames=keys", "export.frames must be one of control, key"),
    ],
)
def test_bad_input_is_one_sentence_before_anything_is_built(override, sentence):
    with pytest.raises(ConfigError) as err:
        check_export(_compose(override))
    assert str(err.value).startswith(sentence) and "\n" not in str(err.value)


def test_default_task_list_is_the_seen_benchmark():
    tasks = export_tasks(_compose())
    assert len(tasks) == 18 and tasks[0] == "close_jar" and "stack_cups" in tasks


def _spec(sim, control_mode):
    import dataclasses

    return dataclasses.replace(sim.control_spec(), control_mode=control_mode)


def test_features_are_the_simulators_control_spec(sim):
    f = feats.features({"front": (64, 64), "wrist": (96, 128)}, _spec(sim, "joint_pos"), use_videos=True)
    assert f["observation.images.wrist"] == {"dtype": "video", "shape": [96, 128, 3], "names": ["height", "width", "channels"]}
    joints = [f"joint_{i}" for i in range(1, 8)]
    assert f["action"]["names"] == [*joints, "gripper"] and f["observation.state"]["shape"] == [16]
    assert f["observation.state"]["names"] == [*joints, "gripper_width", "tcp_x", "tcp_y", "tcp_z", "tcp_qw", "tcp_qx", "tcp_qy",
                                               "tcp_qz", "gripper_open"]
    assert f["action.ee_delta"]["names"] == ["dx", "dy", "dz", "droll", "dpitch", "dyaw", "gripper"]
    assert [k for k in f if k.startswith("action.")] == [f"action.{m}" for m in ("ee_delta", "ee_pose", "joint_pos", "joint_delta")]


def test_key_action_columns_name_the_key_action_each_step_works_towards():
    box = ((-0.5, -0.5, 0.7), (0.5, 0.5, 1.7))
    keys = [KeyAction((0.0, 0.0, 1.0), (1.0, 0.0, 0.0, 0.0), True), KeyAction((0.1, 0.0, 1.0), (1.0, 0.0, 0.0, 0.0), False)]
    cols = key_action_columns([2, 4], keys, 5, box)
    assert cols["key_action.index"].ravel().tolist() == [0, 0, 0, 1, 1]
    assert cols["key_action.ends_here"].ravel().tolist() == [0, 0, 1, 0, 1]
    assert cols["key_action.ints"][0].tolist() == [50, 50, 30, 36, 36, 36, 1]
    assert cols["key_action.ints"][4].tolist()[-1] == 0 and cols["key_action.ints"][4][0] == 60
    assert cols["key_action.pose"][2].tolist() == [0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    np.testing.assert_allclose(cols["key_action.pose"][3], [0.1, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0], atol=1e-7)
    assert feats.key_frame_rows(cols["key_action.index"].ravel()) == [0, 3]


def test_key_frame_features_carry_the_key_pose_and_no_per_step_columns(sim):
    f = feats.features({"front": (64, 64)}, _spec(sim, "joint_pos"), use_videos=False, frames="key")
    assert f["action"]["names"] == ["x", "y", "z", "qw", "qx", "qy", "qz", "gripper"] and f["key_action.pose"]["shape"] == [8]
    assert not [k for k in f if k.startswith("action.")] and "key_action.ends_here" not in f
    assert feats.staged_column("action", "joint_pos", "key") == "key_action.pose"
    assert feats.staged_column("action", "joint_pos") == "action.joint_pos"


def test_provenance_columns_round_trip_and_rebuild_the_envs_arguments():
    from xicm.export.provenance import Provenance, column_names

    options = {"cameras": ["front"], "image_size": 64, "control_mode": "joint_pos", "render": True,
               "sample_variations": False, "scenes": "rlbench"}
    scene = Provenance("close_jar", 10_000, 3, 1, "sapien", options)
    row = {"episode_index": 0, "data/chunk_index": 0, **scene.columns()}  # beside lerobot's own columns
    assert sorted(scene.columns()) == sorted(column_names())
    assert all(k.startswith("scene/") for k in scene.columns()) and Provenance.from_row(row) == scene
    assert scene.env_kwargs(obs_mode="state") == {
        "obs_mode": "state", "simulator": "sapien", "control_mode": "joint_pos", "cameras": ["front"], "image_size": 64,
        "variations": "zero", "simulator_options": {"scenes": "rlbench"}}
    assert scene.reset_kwargs() == {"seed": 10_000, "options": {"episode": 3}}
    with pytest.raises(ValueError, match=r"^the episode metadata has no scene/task, scene/seed, .*scene/simulator_options: "):
        Provenance.from_row({"episode_index": 0})
    assert Provenance.from_row({**row, "scene/seed": np.int64(10_000)}) == scene  # numpy's integers (pandas rows)
    for column, value, words in [("scene/seed", "10000", "scene/seed must be an integer, not '10000'"),
                                 ("scene/variation", True, "scene/variation must be an integer, not 'True'"),
                                 ("scene/simulator_options", "{not json", "scene/simulator_options must be a JSON object, not '{not json'"),
                                 ("scene/simulator_options", "[1]", "scene/simulator_options must be a JSON object, not '[1]'")]:
        with pytest.raises(ValueError) as err:
            Provenance.from_row({**row, column: value})
        assert str(err.value) == f"the episode metadata's {words}", err.value


def test_cli_bad_input_prints_one_sentence_and_no_traceback(tmp_path):
    import subprocess
    import sys

    code = "import sys; from xicm.core.assembly.cli import export_main; sys.argv[0] = 'xicm-export'; export_main()"
    out = subprocess.run(
        [sys.executable, "-c", code, "simulator.image_size=5000", f"hydra.run.dir={tmp_path}"],
        capture_output=True, text=True, timeout=300, cwd=tmp_path,
    )
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert out.stderr.strip().splitlines() == [
        "xicm: error: simulator.image_size must be an integer from 1 to 4096, or [height, width] of two such "
        "integers, or a mapping from camera names (front, left_shoulder, right_shoulder, overhead, wrist) to either, "
        "not 5000"
    ]


@pytest.mark.slow
@pytest.mark.subprocess
def test_worker_processes_record_what_this_process_records(tmp_path):
    """xicm-export's worker pool (src/xicm/core/execution/worker_pool.py, shared with xicm-collect): the same episodes
    recorded in two spawned processes and in this one give the same layout and arrays."""
    from xicm.core.execution.worker_pool import WorkerPool
    from xicm.export.job import _attempt, _facts, _recorder_from

    _, options = check_export(_compose("simulator.image_size=32", "export.cameras=[front]"))
    recorded = {}
    for workers in (1, 2):
        with WorkerPool(workers, _recorder_from, (options, ["front"]), "an export", "nothing to resume") as pool:
            facts = pool.submit(_facts).result()
            futures = [pool.submit(_attempt, "push_buttons", 10_000, e) for e in range(2)]
            recorded[workers] = facts["sizes"], [f.result() for f in futures]
    (sizes_1, alone), (sizes_2, spread) = recorded[1], recorded[2]
    assert sizes_1 == sizes_2 == {"front": (32, 32)}
    for a, b in zip(alone, spread):
        assert (a.episode, a.note, a.error, a.demo is None) == (b.episode, b.note, b.error, b.demo is None)
        if a.demo is not None:
            assert a.demo.arrays.keys() == b.demo.arrays.keys()
            assert all(np.array_equal(a.demo.arrays[k], b.demo.arrays[k]) for k in a.demo.arrays)
    assert any(a.demo is not None for a in alone)


# ------------------------------------------------------------------ a real export (slow)
def _lerobot_env_missing() -> str | None:
    import ctypes.util
    import shutil

    if shutil.which("python3.11") is None:
        return "no python3.11 on PATH to build the lerobot environment from"
    if ctypes.util.find_library("avcodec") is None:
        return "no FFmpeg shared libraries to decode the dataset's videos (apt-get install ffmpeg; scripts/setup.sh does)"
    return None


needs_lerobot = pytest.mark.skipif(_lerobot_env_missing() is not None, reason=str(_lerobot_env_missing()))
TASKS = ["close_jar", "push_buttons"]


def _export_cfg(out_dir: Path, *more: str):
    return _compose(
        f"export.tasks=[{','.join(TASKS)}]", "export.demos_per_task=2", "export.workers=1",
        "simulator.image_size=64", f"export.out_dir={out_dir}", "progress=false", *more,
    )


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    from xicm.lerobot.dataset_writer import read_dataset
    from xicm.export.job import run_export

    out_dir = tmp_path_factory.mktemp("export") / "agnostos_seen"
    cfg = _export_cfg(out_dir)
    report = run_export(cfg)
    loaded = tmp_path_factory.mktemp("read") / "loaded.npz"
    read_dataset(out_dir, cfg.export.repo_id, loaded, cfg.paths.cache)
    return cfg, out_dir, report, dict(np.load(loaded)), report["staged"]


@pytest.mark.slow
@pytest.mark.venv
@needs_lerobot
def test_export_loads_with_lerobot_with_every_frame_task_and_column(exported, sim):
    import json

    cfg, out_dir, report, data, staged = exported
    assert report["counts"] == {"close_jar": (2, 2), "push_buttons": (2, 2)}
    assert [(p.parent.parent.name, p.name) for p in staged] == [
        ("close_jar", "e0000.npz"), ("close_jar", "e0001.npz"), ("push_buttons", "e0000.npz"), ("push_buttons", "e0001.npz")]
    steps = [len(np.load(p)["action.ee_delta"]) for p in staged]
    assert int(data["num_episodes"]) == 4 and int(data["num_frames"]) == sum(steps)
    assert data["tasks"].tolist() == [str(np.load(p)["instruction"]) for p in staged]
    features = json.loads(str(data["features"]))
    expected = feats.features({"front": (64, 64), "wrist": (64, 64)}, _spec(sim, "ee_delta"), use_videos=True)
    assert {k: features[k]["shape"] for k in expected} == {k: v["shape"] for k, v in expected.items()}
    assert (out_dir / "meta" / "info.json").exists() and list((out_dir / "videos").rglob("*.mp4"))
    first = 0
    for n, path in enumerate(staged):
        arrays = np.load(path)
        rows = slice(first, first + steps[n])
        for space in sim.control_spec().mode_names(per_step=True):
            np.testing.assert_allclose(data[f"column.action.{space}"][rows], arrays[f"action.{space}"], atol=1e-6)
        np.testing.assert_array_equal(data["column.action"][rows], data["column.action.ee_delta"][rows])
        np.testing.assert_array_equal(data["column.key_action.ints"][rows], arrays["key_action.ints"])
        for camera in ("front", "wrist"):  # the decoded video frame is the recorded picture, up to compression
            diff = np.abs(data[f"images.{camera}"][n, 0].astype(int) - arrays[f"observation.images.{camera}"][0].astype(int))
            assert diff.mean() < 8, (path, camera, diff.mean())
        first += steps[n]


@pytest.mark.slow
@pytest.mark.venv
@needs_lerobot
def test_loaded_actions_replay_to_success_in_the_gymnasium_env_in_every_action_space(exported, sim):
    import gymnasium

    from xicm.export.provenance import from_dump
    from xicm.vla.registration import env_id, register_envs

    register_envs()
    _, _, _, data, staged = exported
    episode_of = data["column.episode_index"].reshape(-1)
    scenes = from_dump(data)  # each episode's (task, seed, episode), read from the dataset itself
    results = []
    for space in sim.control_spec().mode_names(per_step=True):
        for task in TASKS:
            env = gymnasium.make(env_id(task), obs_mode="state", control_mode=space)
            try:
                for n, path in enumerate(staged):
                    if scenes[n].task != task:
                        continue
                    _, info = env.reset(**scenes[n].reset_kwargs())
                    assert info["instruction"] == data["tasks"][n]  # the dataset's task text is this scene's
                    for action in data[f"column.action.{space}"][episode_of == n]:
                        _, _, terminated, truncated, info = env.step(action)
                        assert "error_kind" not in info, (space, path, info)
                        if terminated or truncated:
                            break
                    results.append((space, task, path.stem, terminated and info["success"]))
            finally:
                env.close()
    assert len(results) == 16 and all(ok for *_, ok in results), results


@pytest.mark.slow
@pytest.mark.venv
@needs_lerobot
def test_each_episode_names_its_scene_and_the_env_rebuilt_from_it_alone_replays_it(exported):
    """The dataset names each episode's scene (meta/episodes' scene/* columns, read back by
    lerobot's LeRobotDataset): the Gymnasium env built and reset from those columns alone shows
    the episode's first frame and state, and the episode's `action` column solves it."""
    import gymnasium

    from xicm.export.provenance import from_dump
    from xicm.export.staging import staged_scene
    from xicm.vla.registration import env_id, register_envs

    register_envs()
    _, _, _, data, staged = exported
    scenes = from_dump(data)
    assert [(s.task, s.seed, s.episode, s.variation) for s in scenes] == [staged_scene(p) for p in staged]
    assert {(s.simulator, s.simulator_options["control_mode"], s.simulator_options["image_size"]) for s in scenes} == {
        ("sapien", "ee_delta", 64)}
    episode_of = data["column.episode_index"].reshape(-1)
    for n, scene in enumerate(scenes):
        env = gymnasium.make(env_id(scene.task), **scene.env_kwargs(obs_mode="rgb"))
        try:
            obs, info = env.reset(**scene.reset_kwargs())
            assert (info["instruction"], info["variation"]) == (data["tasks"][n], scene.variation)
            rows = episode_of == n
            state = np.concatenate([obs["state"][f.name] for f in env.unwrapped.control_spec.state])
            np.testing.assert_allclose(state, data["column.observation.state"][rows][0], atol=1e-5)
            for camera in scene.simulator_options["cameras"]:  # the decoded first video frame, up to compression
                diff = np.abs(obs["rgb"][camera].astype(int) - data[f"images.{camera}"][n, 0].astype(int))
                assert diff.mean() < 8, (scene, camera, diff.mean())
            for action in data["column.action"][rows]:
                _, _, terminated, truncated, info = env.step(action)
                assert "error_kind" not in info, (scene, info)
                if terminated or truncated:
                    break
            assert terminated and info["success"], scene
        finally:
            env.close()


@pytest.mark.slow
@pytest.mark.venv
@needs_lerobot
def test_a_partial_export_resumes_recording_only_what_is_missing(exported, monkeypatch, tmp_path):
    import shutil

    from xicm.export import record
    from xicm.lerobot.dataset_writer import read_dataset
    from xicm.export.job import run_export

    cfg, out_dir, _, _, staged = exported
    work = tmp_path / out_dir.name  # a copy of the export as a kill would leave it:
    shutil.copytree(out_dir.with_name(f"{out_dir.name}.staging"), work.with_name(f"{work.name}.staging"))
    lost = work.with_name(f"{work.name}.staging") / staged[-1].relative_to(out_dir.with_name(f"{out_dir.name}.staging"))
    lost.unlink()  # the last episode never staged, no dataset yet, the writer's temp folder half-written
    (work.with_name(f".{work.name}.tmp") / "meta").mkdir(parents=True)
    recorded = []
    real = record.record_episode
    monkeypatch.setattr(record, "record_episode", lambda sim, task, *a: recorded.append(task) or real(sim, task, *a))
    report = run_export(_export_cfg(work))
    assert recorded == ["push_buttons"] and report["episodes"] == 4
    assert not work.with_name(f".{work.name}.tmp").exists()
    loaded = tmp_path / "loaded.npz"
    read_dataset(work, cfg.export.repo_id, loaded, cfg.paths.cache)
    assert int(np.load(loaded)["num_episodes"]) == 4


@pytest.mark.slow
@pytest.mark.venv
@needs_lerobot
def test_key_frames_of_the_same_staging_load_with_lerobot_and_replay_to_success(exported, monkeypatch, tmp_path):
    """export.frames=key writes the staged demos again, without recording anything, as one frame
    per key action whose `action` is the key pose; executing those poses solves each scene."""
    import shutil

    from xicm.core.assembly.plugins import get_registry
    from xicm.export import record
    from xicm.lerobot.dataset_writer import read_dataset
    from xicm.export.job import run_export
    from xicm.export.provenance import from_dump

    cfg, out_dir, _, _, staged = exported
    work = tmp_path / "agnostos_seen_key"
    shutil.copytree(out_dir.with_name(f"{out_dir.name}.staging"), work.with_name(f"{work.name}.staging"))
    monkeypatch.setattr(record, "record_episode", lambda *a: pytest.fail("a staged episode was recorded again"))
    assert run_export(_export_cfg(work, "export.frames=key"))["episodes"] == 4
    loaded = tmp_path / "loaded.npz"
    read_dataset(work, cfg.export.repo_id, loaded, cfg.paths.cache)
    data = dict(np.load(loaded))
    assert from_dump(data) == from_dump(exported[3])  # the key-frame episodes name the same scenes
    keys = [int(np.load(p)["key_action.index"].max()) + 1 for p in staged]
    assert int(data["num_frames"]) == sum(keys) and json.loads(str(data["features"]))["action"]["names"] == list(KEY_POSE_NAMES)
    episode_of = data["column.episode_index"].reshape(-1)
    simulator = get_registry().create_simulator({"name": "sapien", "cameras": ["front"]})
    try:
        for n, path in enumerate(staged):
            poses = data["column.action"][episode_of == n]
            np.testing.assert_array_equal(poses, data["column.key_action.pose"][episode_of == n])
            assert data["column.key_action.index"][episode_of == n].ravel().tolist() == list(range(keys[n]))
            simulator.reset(path.parent.parent.name, int(cfg.export.seed), int(path.stem[1:]))
            outcomes = [simulator.execute(KeyAction(tuple(p[:3]), tuple(p[3:7]), bool(p[7] >= 0.5))) for p in poses]
            assert all(o.ok for o in outcomes) and outcomes[-1].success, (path, outcomes)
    finally:
        simulator.close()


@pytest.mark.slow
@pytest.mark.venv
@needs_lerobot
def test_lerobot_trains_on_the_export_and_writes_a_servable_checkpoint(exported, tmp_path):
    """xicm-train-lerobot runs lerobot's own training script on the exported dataset (2 steps
    of a tiny ACT here; the recipe's sizes are for real runs)."""
    import subprocess
    import sys

    _, out_dir, _, _, _ = exported
    tiny = ["--policy.dim_model=32", "--policy.n_heads=2", "--policy.dim_feedforward=64", "--policy.n_encoder_layers=1",
            "--policy.n_vae_encoder_layers=1", "--policy.chunk_size=4", "--policy.n_action_steps=4"]
    cmd = [str(Path(sys.executable).parent / "xicm-train-lerobot"), str(out_dir), str(tmp_path / "train"), "--steps=2",
           "--batch-size=2", "--", *tiny]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, (done.stdout + done.stderr)[-3000:]
    model = tmp_path / "train" / "checkpoints" / "000002" / "pretrained_model"
    config = json.loads((model / "config.json").read_text())
    assert config["type"] == "act" and config["chunk_size"] == 4 and config["dim_model"] == 32
    assert set(config["input_features"]) == {"observation.images.front", "observation.images.wrist", "observation.state"}
    assert (model / "model.safetensors").stat().st_size > 0 and (model / "policy_preprocessor.json").is_file()

    # --resume goes on from the last checkpoint (lerobot's own resume: its optimizer and step)
    done = subprocess.run([*cmd[:3], "--resume", "--steps=3"], capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, (done.stdout + done.stderr)[-3000:]
    state = tmp_path / "train" / "checkpoints" / "000003" / "training_state" / "training_step.json"
    assert json.loads(state.read_text())["step"] == 3 and (model / "model.safetensors").is_file()  # 000002 kept


def test_train_lerobot_refuses_to_overwrite_a_run_or_resume_nothing(tmp_path):
    import subprocess
    import sys

    dataset, out = tmp_path / "data", tmp_path / "out"
    (dataset / "meta").mkdir(parents=True)
    (dataset / "meta" / "info.json").write_text("{}")
    out.mkdir()
    script = str(Path(sys.executable).parent / "xicm-train-lerobot")
    again = subprocess.run([script, str(dataset), str(out)], capture_output=True, text=True, timeout=120)
    assert again.returncode == 2 and f"{out} exists; --resume continues its run" in again.stderr
    resume = subprocess.run([script, str(dataset), str(out), "--resume"], capture_output=True, text=True, timeout=120)
    assert resume.returncode == 2 and "--resume needs a run with a checkpoint" in resume.stderr


def test_train_lerobot_refuses_a_folder_that_is_not_a_dataset(tmp_path):
    import subprocess
    import sys

    done = subprocess.run([str(Path(sys.executable).parent / "xicm-train-lerobot"), str(tmp_path), str(tmp_path / "out")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and f"{tmp_path} is not a LeRobot dataset (no meta/info.json)" in done.stderr
