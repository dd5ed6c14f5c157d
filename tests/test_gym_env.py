"""The Gymnasium API (xicm.vla): every task as "xicm/<CamelCaseTask>-v0"."""

import functools
import hashlib
import subprocess
import sys

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

import xicm.vla  # noqa: E402,F401 - registers the env ids
from xicm.core.contracts.errors import ConfigError  # noqa: E402

SMALL = {"obs_mode": "rgb", "render_mode": "rgb_array", "cameras": ["front"], "image_size": 32}


def test_every_registered_task_has_an_env_id():
    from xicm.core.assembly.plugins import get_registry

    tasks = list(get_registry().tasks(simulator="sapien"))
    assert len(tasks) == 41
    assert xicm.vla.env_id("put_money_in_safe") == "xicm/PutMoneyInSafe-v0"
    assert all(xicm.vla.env_id(t) in gymnasium.registry for t in tasks)


@pytest.mark.parametrize("task, mode", [("open_drawer", "ee_delta"), ("push_buttons", "joint_pos"), ("lamp_on", "ee_pose")])
def test_check_env_passes(task, mode):
    from gymnasium.utils.env_checker import check_env

    env = gymnasium.make(xicm.vla.env_id(task), control_mode=mode, **SMALL)
    try:
        with _no_checker_warnings():
            check_env(env.unwrapped)
    finally:
        env.close()


class _no_checker_warnings:
    """check_env reports problems as warnings: fail on any from gymnasium, except its advice to
    normalise Box action spaces to [-1, 1] (joint_pos / ee_pose are in radians and metres on purpose)."""

    def __enter__(self):
        import warnings

        self._catch = warnings.catch_warnings(record=True)
        self.caught = self._catch.__enter__()
        warnings.simplefilter("always")
        return self

    def __exit__(self, *exc):
        self._catch.__exit__(*exc)
        advice = "we recommend using a symmetric and normalized space"
        gym_warnings = [str(w.message) for w in self.caught if "gymnasium" in str(w.filename) and advice not in str(w.message)]
        assert gym_warnings == []


def test_a_replayed_recording_succeeds_terminates_and_reports_the_instruction():
    env = gymnasium.make("xicm/OpenDrawer-v0", obs_mode="state", control_mode="joint_delta")
    try:
        obs, info = env.reset(seed=10_000, options={"episode": 0})
        assert info["instruction"] == env.unwrapped.instruction == "open the bottom drawer"  # this episode's variation
        assert obs["state"]["joint_positions"].dtype == np.float32 and set(obs) == {"state"}
        sim = env.unwrapped.sim
        rec = sim.record_scripted()
        env.reset(seed=10_000, options={"episode": 0})
        for t, action in enumerate(rec.actions["joint_delta"]):
            obs, reward, terminated, truncated, info = env.step(action.astype(np.float32))
            if terminated or truncated:
                break
        assert (terminated, truncated, reward, info["success"]) == (True, False, 1.0, True)
    finally:
        env.close()


def test_the_episode_is_truncated_at_max_control_steps():
    env = gymnasium.make("xicm/OpenDrawer-v0", obs_mode="state", control_mode="ee_delta", max_control_steps=3)
    try:
        env.reset(seed=0)
        hold = np.array([0, 0, 0, 0, 0, 0, 1], np.float32)
        flags = [env.step(hold)[2:4] for _ in range(3)]
        assert flags == [(False, False), (False, False), (False, True)]
    finally:
        env.close()


def test_an_unreachable_step_says_why_in_info_and_leaves_the_state():
    env = gymnasium.make("xicm/OpenDrawer-v0", obs_mode="state", control_mode="ee_pose")
    try:
        obs, _ = env.reset(seed=0)
        after, _, terminated, _, info = env.step(np.array([3.0, 0, 0.5, 1, 0, 0, 0, 1], np.float32))
        assert info["error_kind"] == "unreachable" and not terminated
        np.testing.assert_array_equal(after["state"]["joint_positions"], obs["state"]["joint_positions"])
    finally:
        env.close()


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"obs_mode": "pointcloud"}, "obs_mode must be one of state, rgb, rgbd, not 'pointcloud'"),
        ({"control_mode": "pd_ee_delta_pose"}, "simulator.control_mode must be one of ee_delta"),
        ({"cameras": ["front", "back"]}, "simulator.cameras must be a non-empty list of distinct names from"),
        ({"image_size": 0}, "simulator.image_size must be an integer from 1 to 4096"),
        ({"image_size": 5000}, "simulator.image_size must be an integer from 1 to 4096"),
        ({"image_size": {"front": 224, "back": 64}}, "or a mapping from camera names"),
    ],
)
def test_bad_env_arguments_are_one_sentence(kwargs, words):
    with pytest.raises(ConfigError) as info:
        gymnasium.make("xicm/OpenDrawer-v0", **kwargs)
    assert words in str(info.value)


def test_image_size_per_camera():
    env = gymnasium.make("xicm/OpenDrawer-v0", cameras=["front", "wrist"], image_size={"front": [24, 40], "wrist": 16})
    try:
        obs, _ = env.reset(seed=0)
        assert obs["rgb"]["front"].shape == (24, 40, 3) and obs["rgb"]["wrist"].shape == (16, 16, 3)
        assert env.observation_space["rgb"]["front"].shape == (24, 40, 3)
    finally:
        env.close()


RESET_DIGEST = """
import hashlib, gymnasium, numpy as np
env = gymnasium.make("xicm.vla:xicm/PushButtons-v0", obs_mode="rgb", cameras=["front", "wrist"], image_size=48)
obs, info = env.reset(seed=7, options={"episode": 3})
h = hashlib.sha256()
for part in ("state", "rgb"):
    for k in sorted(obs[part]):
        h.update(np.ascontiguousarray(obs[part][k]).tobytes())
print(info["instruction"], "|", h.hexdigest())
"""


@pytest.mark.slow
@pytest.mark.subprocess
def test_reset_gives_the_same_observation_bytes_in_two_processes():
    runs = [subprocess.run([sys.executable, "-c", RESET_DIGEST], capture_output=True, text=True, timeout=300) for _ in range(2)]
    outputs = [r.stdout.strip().splitlines()[-1] for r in runs]
    assert all(r.returncode == 0 for r in runs), runs[0].stderr[-2000:]
    assert outputs[0] == outputs[1] and len(outputs[0].split("|")[1].strip()) == 64


@pytest.mark.slow
@pytest.mark.subprocess
def test_async_vector_env_steps_two_different_tasks_in_worker_processes():
    from gymnasium.vector import AsyncVectorEnv

    kwargs = {"obs_mode": "rgb", "cameras": ["front"], "image_size": 32, "control_mode": "ee_delta"}
    fns = [functools.partial(gymnasium.make, f"xicm.vla:xicm/{name}-v0", **kwargs) for name in ("OpenDrawer", "PushButtons")]
    envs = AsyncVectorEnv(fns, context="spawn")
    try:
        obs, infos = envs.reset(seed=[0, 0])
        assert obs["rgb"]["front"].shape == (2, 32, 32, 3)
        assert "drawer" in infos["instruction"][0] and "button" in infos["instruction"][1]
        down = np.tile(np.array([0, 0, -0.02, 0, 0, 0, 1], np.float32), (2, 1))
        for _ in range(3):
            obs, rewards, terminated, truncated, infos = envs.step(down)
        assert rewards.shape == (2,) and not terminated.any() and not truncated.any()
        assert np.all(obs["state"]["tcp_pose"][:, 2] < 0.5 - 0.03)  # both arms went down from z = 0.5
    finally:
        envs.close()


def test_the_spaces_are_the_simulators_control_spec():
    env = gymnasium.make("xicm/OpenDrawer-v0", obs_mode="state", control_mode="ee_pose")
    try:
        spec = env.unwrapped.sim.control_spec()
        low, high = spec.mode("ee_pose").bounds()
        np.testing.assert_array_equal(env.action_space.low, low)
        np.testing.assert_array_equal(env.action_space.high, high)
        state = env.observation_space["state"]
        assert set(state.spaces) == {f.name for f in spec.state}  # gymnasium sorts a Dict's keys
        assert [state[f.name].shape for f in spec.state] == [(f.width,) for f in spec.state]
    finally:
        env.close()
