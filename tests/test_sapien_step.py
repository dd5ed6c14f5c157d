"""Per-step control of the SAPIEN simulator: step(action) in the four control modes, proprio,
control-rate recordings of scripted demos and replaying them (src/xicm/plugins/simulators/sapien)."""

import numpy as np
import pytest

from xicm.core.contracts.errors import ConfigError

SEED = 10_000  # the collection seed: the scenes a training set is recorded on


@pytest.fixture(scope="module")
def physics():
    from xicm.core.assembly.plugins import get_registry

    simulator = get_registry().create_simulator({"name": "sapien", "render": False})
    yield simulator
    simulator.close()


@pytest.mark.parametrize("task", ["open_drawer", "push_buttons", "put_money_in_safe", "lamp_on"])
def test_a_recorded_demo_replays_to_success_in_every_control_mode(physics, task):
    from xicm.plugins.simulators.sapien.replay import replay_steps

    physics.reset_state(task, SEED, 0)
    rec = physics.recording = physics.record_scripted()
    assert rec.success, rec.error
    failed = {}
    for mode in physics.control_spec().mode_names(per_step=True):
        ok, error = replay_steps(physics, rec, mode)
        if not ok:
            failed[mode] = error
    physics.control_mode = "ee_delta"
    assert failed == {}


def test_a_recording_has_one_row_per_control_step_and_key_actions_in_order(physics):
    from xicm.plugins.simulators.sapien.control_modes import ACTION_DIMS, actions

    physics.reset_state("open_drawer", SEED, 1)
    rec = physics.record_scripted()
    t = rec.steps
    assert t > 5 and rec.rgb is None and rec.control_hz == 10.0
    assert rec.joint_targets.shape == (t + 1, 7) and rec.tcp_targets.shape == (t + 1, 7)
    assert {k: v.shape for k, v in rec.proprio.items()} == {
        "joint_positions": (t + 1, 7), "gripper_width": (t + 1, 1), "tcp_pose": (t + 1, 7), "gripper_open": (t + 1, 1)
    }
    assert rec.key_action_steps == sorted(rec.key_action_steps) and rec.key_action_steps[-1] == t - 1
    assert len(rec.key_actions) == len(rec.key_action_steps)
    for mode, dim in ACTION_DIMS.items():
        assert actions(rec, mode).shape == (t, dim)
        np.testing.assert_array_equal(rec.actions[mode], actions(rec, mode))  # the recording carries them
    assert sorted(rec.actions) == sorted(physics.control_spec().mode_names(per_step=True))


def test_a_recording_renders_the_chosen_cameras_per_control_step(sim):
    sim.reset_state("push_buttons", SEED, 0)
    rec = sim.record_scripted(cameras=["front", "wrist"])
    assert sorted(rec.rgb) == ["front", "wrist"]
    assert rec.rgb["wrist"].shape == (rec.steps + 1, 128, 128, 3) and rec.rgb["wrist"].dtype == np.uint8
    assert not np.array_equal(rec.rgb["front"][0], rec.rgb["front"][-1])  # the arm moved


def test_proprio_is_in_the_robot_base_frame_and_in_the_observation(sim):
    obs = sim.reset("open_drawer", 0, 0)
    p = obs.proprio
    assert {k: v.shape for k, v in p.items()} == {
        "joint_positions": (7,), "gripper_width": (1,), "tcp_pose": (7,), "gripper_open": (1,)
    }
    # the base stands at (-0.35, 0, 0.75) unrotated: base-frame xyz = world xyz - base
    world = np.asarray(obs.gripper.position)
    np.testing.assert_allclose(p["tcp_pose"][:3], world - np.array([-0.35, 0.0, 0.75]), atol=1e-5)
    assert p["gripper_open"][0] == 1.0 and p["gripper_width"][0] == pytest.approx(0.08, abs=1e-3)


def test_an_ee_delta_step_moves_the_gripper_by_the_delta(physics):
    physics.control_mode = "ee_delta"
    physics.reset_state("open_drawer", 0, 0)
    before = physics.proprio()["tcp_pose"][:3]
    for _ in range(5):
        assert physics.step([0.0, 0.0, -0.02, 0.0, 0.0, 0.0, 1.0]).ok
    for _ in range(5):  # hold still so the arm catches up with its target
        assert physics.step([0.0] * 6 + [1.0]).ok
    moved = physics.proprio()["tcp_pose"][:3] - before
    np.testing.assert_allclose(moved, [0.0, 0.0, -0.1], atol=0.01)


def test_a_closing_step_closes_the_gripper(physics):
    physics.control_mode = "joint_delta"
    physics.reset_state("open_drawer", 0, 0)
    for _ in range(6):
        assert physics.step([0.0] * 7 + [0.0]).ok
    assert physics.proprio()["gripper_open"][0] == 0.0 and physics.proprio()["gripper_width"][0] < 0.005
    physics.control_mode = "ee_delta"


@pytest.mark.parametrize(
    "mode, action, kind, words",
    [
        ("ee_delta", [0.0] * 6, "bad_action", "shape (7,)"),
        ("joint_pos", [0.0] * 7 + [float("nan")], "bad_action", "NaN or infinite values at index(es) [7]"),
        ("ee_delta", [0.0, float("inf")] + [0.0] * 5, "bad_action", "NaN or infinite"),
        ("ee_pose", "left", "bad_action", "must be 8 numbers, not a str"),
        ("ee_pose", [3.0, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0, 1.0], "unreachable", "no joint configuration"),
        ("ee_pose", [0.4, 0.0, 0.3, 0.0, 0.0, 0.0, 0.0, 1.0], "unreachable", "quaternion has zero length"),
        ("joint_pos", [0.0, 0.0, 0.0, 0.5, 0.0, 1.6, 0.8, 1.0], "unreachable", "outside the Panda's limits at joint(s) [4]"),
        ("joint_delta", [0.0] * 6 + [5.0, 1.0], "unreachable", "joint(s) [7]"),
    ],
)
def test_a_bad_or_unreachable_action_is_a_failed_step_with_one_sentence(physics, mode, action, kind, words):
    physics.control_mode = mode
    physics.reset_state("open_drawer", 0, 0)
    before = physics.proprio()["joint_positions"]
    outcome = physics.step(action)
    physics.control_mode = "ee_delta"
    assert (outcome.ok, outcome.error_kind) == (False, kind)
    assert words in outcome.error_message and outcome.error_message.count(". ") == 0
    np.testing.assert_array_equal(physics.proprio()["joint_positions"], before)  # nothing moved


@pytest.mark.parametrize(
    "options, words",
    [
        ({"control_mode": "cartesian"}, "simulator.control_mode must be one of ee_delta, ee_pose, joint_pos, joint_delta, not 'cartesian'"),
        ({"frame_hz": 20, "control_hz": 15}, "simulator.frame_hz (20) must be a whole multiple of simulator.control_hz (15)"),
        ({"frame_hz": 20, "control_hz": 40}, "must be a whole multiple"),
    ],
)
def test_bad_control_options_are_one_sentence_before_anything_is_built(options, words):
    from xicm.core.assembly.plugins import get_registry

    with pytest.raises(ConfigError, match=None) as info:
        registry = get_registry()
        registry.check_options("simulator", {"name": "sapien", **options})
        registry.get("simulator", "sapien").extra["check"]({"name": "sapien", **options})
    assert words in str(info.value)


def test_a_simulator_without_per_step_control_says_so_by_name():
    from xicm.core.contracts.interfaces import Simulator

    class KeyOnly(Simulator):
        task_names = task_info = reset = observe = execute = is_success = demonstrate = lambda *a: None

    with pytest.raises(NotImplementedError, match="KeyOnly has no per-step control"):
        KeyOnly().step([0.0] * 7)
    with pytest.raises(NotImplementedError, match="KeyOnly declares no control modes"):
        KeyOnly().control_spec()
    with pytest.raises(NotImplementedError, match="KeyOnly cannot record scripted demos"):
        KeyOnly().record_scripted()
