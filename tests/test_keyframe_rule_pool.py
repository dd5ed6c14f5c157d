"""policy.keyframes: xicm re-derives the pool's key actions from its stored trajectories with
X-ICM's key-frame rule; demos whose key frames do not change keep their stored actions."""

import numpy as np
import pytest

from xicm.core.text import encoding
from xicm.core.results.dataset import load_pool
from xicm.core.contracts.errors import ConfigError
from xicm.core.contracts.interfaces import PolicyContext
from xicm.core.assembly.plugins import get_registry
from xicm.core.contracts.types import Demo, KeyAction, Trajectory
from xicm.plugins.policies.xicm import XicmPolicyOptions, create_xicm_policy
from xicm.plugins.policies.xicm.parts import rederive_key_actions

MOVING, STILL = [0.5] * 7, [0.0] * 7


def _demo(name, grip):
    vel = [MOVING, STILL, MOVING, MOVING, MOVING, STILL] + [MOVING] * 6
    n = len(grip)
    poses = np.tile([0.0, 0, 1, 1, 0, 0, 0], (n, 1)) + np.arange(n)[:, None] * [0.01, 0, 0, 0, 0, 0, 0]
    traj = Trajectory(np.zeros((n, 7)), np.asarray(vel, float), np.asarray(grip, bool), poses, success=True)
    stored = encoding.key_actions_from_trajectory(traj)
    return Demo(f"close_jar/s0/{name}", "close_jar", "close the red jar", 0, 0, {}, stored, trajectory=traj)


def test_only_demos_whose_key_frames_change_get_new_key_actions():
    wraps, steady = _demo("e0", [True] * 12), _demo("e1", [True] * 11 + [False])
    kept = steady.key_actions
    assert rederive_key_actions([wraps, steady], "xicm") == ["close_jar/s0/e0"]
    assert [round(a.position[0], 3) for a in wraps.key_actions] == [0.01, 0.11]  # frames 1 and 11
    assert steady.key_actions is kept
    assert wraps.trajectory is None and steady.trajectory is None


def test_a_demo_without_its_trajectory_is_refused_in_one_sentence():
    demo = Demo("close_jar/s0/e0", "close_jar", "close the red jar", 0, 0, {}, [KeyAction((0, 0, 1), (1, 0, 0, 0), True)])
    with pytest.raises(ConfigError, match="has no stored trajectory, so policy.keyframes=xicm cannot re-derive"):
        rederive_key_actions([demo], "xicm")


def test_the_factory_reads_the_pool_file_with_the_xicm_rule(sim, smoke_pool):
    path, _ = smoke_pool
    cfg_groups = {
        "detector": {"name": "oracle"}, "encoder": {"name": None}, "retriever": {"name": "random"},
        "prompt": {"name": "xicm_paper"}, "llm": {"name": "nearest_demo"},
        "llm_cache": {"enabled": False, "path": "/nonexistent/responses.sqlite"},
    }
    from omegaconf import OmegaConf

    context = PolicyContext(OmegaConf.create(cfg_groups), get_registry(), sim)
    options = XicmPolicyOptions(2, None, str(path), ["open_drawer", "push_buttons"], keyframes="xicm")
    policy = create_xicm_policy(options, context)
    stored = load_pool(path, with_images=False, with_trajectories=True)
    for built, demo in zip(policy.pool, stored):
        t = demo.trajectory
        assert built.key_actions == encoding.key_actions_from_trajectory(t, rule="xicm") or (
            encoding.keyframe_indices(t.joint_velocities, t.gripper_open, rule="xicm")
            == encoding.keyframe_indices(t.joint_velocities, t.gripper_open)
            and built.key_actions == demo.key_actions
        )
        assert built.trajectory is None
