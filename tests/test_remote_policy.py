"""policy=remote against real servers on 127.0.0.1: what bad replies do to an episode, and a
served oracle reaching exactly the oracle's episodes."""

import dataclasses
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from serve_wait import wait_for_serving

from xicm.core.assembly.build import Run
from xicm.core.execution.episode import run_episode
from xicm.core.contracts.errors import EpisodeFailure
from xicm.core.contracts.interfaces import Policy
from xicm.plugins.policies.oracle import OraclePolicy
from xicm.plugins.policies.remote import RemotePolicy, RemotePolicyOptions
from xicm.serving.client import PolicyClient, server_uri
from xicm.serving.ports import free_port
from xicm.serving.served_policy import ServedPolicy
from xicm.serving.server import PolicyServer

TASK = "open_drawer"


class Replies:
    """A server-side policy that answers each request with the next scripted reply."""

    def __init__(self, *replies):
        self.replies = list(replies)

    def infer(self, obs):
        reply = self.replies.pop(0)
        if isinstance(reply, Exception):
            raise reply
        if isinstance(reply, float):
            time.sleep(reply)
            return {"actions": np.zeros((1, 8))}
        return reply


def remote(port, spec, timeout_s=10.0, **options):
    client = PolicyClient(server_uri("127.0.0.1", port), timeout_s)
    client.connect()
    opts = {**dataclasses.asdict(RemotePolicyOptions()), "control_mode": "key_pose", "state_key": None, **options}
    return RemotePolicy(client, opts, spec)


@pytest.mark.parametrize(
    "reply, kind, words",
    [
        ({"actions": np.zeros((2, 5))}, "bad_reply", "shape (2, 5); control mode key_pose needs (N, 8)"),
        ({"actions": np.full((1, 8), np.nan)}, "bad_reply", "NaN or infinite"),
        ({"act": np.zeros((1, 8))}, "bad_reply", "no 'actions' (keys: act)"),
        (RuntimeError("CUDA out of memory"), "server_error", "RuntimeError: CUDA out of memory"),
        (3.0, "server_timeout", "did not answer within 1 s"),
    ],
)
def test_a_bad_reply_fails_the_episode_with_a_reason_and_the_next_one_runs(sim, reply, kind, words):
    # the second reply is a reachable pose above the table: that episode runs its key action
    good = {"actions": np.array([[0.1, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 1.0]])}
    server = PolicyServer(Replies(reply, good), port=0).start()
    try:
        policy = remote(server.port, sim.control_spec(), timeout_s=1.0)
        first = run_episode(sim, policy, TASK, 0, 0, max_steps=1)
        assert (first.success, first.error_kind) == (False, kind) and words in first.error_message
        if kind == "server_timeout":
            time.sleep(2.5)  # the server finishes the slow request before it answers the next
        second = run_episode(sim, policy, TASK, 0, 1, max_steps=1)
        assert second.steps == 1 and second.error_kind == "max_steps", second.error_message
    finally:
        server.stop()


def test_the_observation_is_mapped_to_the_servers_keys(sim):
    seen = []

    class Recorder:
        def infer(self, obs):
            seen.append(obs)
            return {"actions": np.array([[0.1, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 1.0]])}

    server = PolicyServer(Recorder(), port=0).start()
    try:
        policy = remote(server.port, sim.control_spec(), images={"front": "observation/image", "wrist": "observation/wrist_image"}, image_size=64,
                        state_key="observation/state", state=["joint_positions", "gripper_width"])
        run_episode(sim, policy, TASK, 0, 0, max_steps=1)
    finally:
        server.stop()
    obs = seen[0]
    assert obs["observation/image"].shape == (64, 64, 3) and obs["observation/image"].dtype == np.uint8
    assert obs["observation/wrist_image"].shape == (64, 64, 3)
    assert obs["observation/state"].shape == (8,) and obs["observation/state"].dtype == np.float32
    assert obs["prompt"] == sim.observe(["front"]).instruction  # the episode's instruction (its variation)
    assert obs["xicm/episode"] == {"task": TASK, "seed": 0, "episode": 0, "call": 0}


def test_a_served_oracle_plays_exactly_the_oracles_episodes(sim):
    from xicm.core.assembly.plugins import get_registry

    server_sim = get_registry().create_simulator({"name": "sapien", "image_size": 32, "cameras": ["front"]})
    served = ServedPolicy(Run(server_sim, OraclePolicy(server_sim), "oracle"))
    server = PolicyServer(served, port=0, metadata=served.metadata()).start()
    try:
        policy = remote(server.port, sim.control_spec(), control_mode="auto", images={})
        assert policy.observes is False and policy.control_mode == "key_pose"
        for task, episode in (("open_drawer", 0), ("push_buttons", 1)):
            over_the_wire = run_episode(sim, policy, task, 0, episode)
            local = run_episode(sim, OraclePolicy(sim), task, 0, episode)
            assert (over_the_wire.success, over_the_wire.steps, over_the_wire.error_kind) == (local.success, local.steps, local.error_kind)
            assert local.success
    finally:
        server.stop()
        server_sim.close()


class InstructionsSeen(Policy):
    """Records the instruction of every observation it is reset with or asked on, then gives up."""

    observes = True

    def __init__(self):
        self.seen: list[tuple[str, str]] = []

    def reset(self, task, obs, rng) -> None:
        self.seen.append(("reset", obs.instruction))

    def act(self, obs):
        self.seen.append(("act", obs.instruction))
        raise EpisodeFailure("no_actions", "this policy only records instructions")


def test_a_served_episode_reads_the_same_reworded_instruction_as_a_local_one(sim):
    """benchmark.instructions=sampled rewords variation 0's instruction per episode: the server
    starts its episodes as a local run does (core.episode.start_episode), even for a client
    that does not reword."""
    from xicm.core.assembly.plugins import get_registry

    task, episodes = "close_fridge", range(4)
    server_sim = get_registry().create_simulator({"name": "sapien", "image_size": 32, "cameras": ["front"]})
    server_sim.sample_variations = False
    served_policy = InstructionsSeen()
    served = ServedPolicy(Run(server_sim, served_policy, "instructions"), instructions="sampled")
    server = PolicyServer(served, port=0, metadata=served.metadata()).start()
    kept, sim.sample_variations = sim.sample_variations, False  # variation 0: the one reworded
    try:
        local_policy = InstructionsSeen()
        for episode in episodes:
            run_episode(sim, local_policy, task, 0, episode, instructions="sampled")
            client = remote(server.port, sim.control_spec(), control_mode="auto", images={})
            failed = run_episode(sim, client, task, 0, episode, instructions="agnostos")
            assert failed.error_kind == "no_actions"
    finally:
        sim.sample_variations = kept
        server.stop()
        server_sim.close()
    assert served_policy.seen == local_policy.seen
    plain = sim.task_info(task).instruction
    assert len({text for _, text in local_policy.seen} - {plain}) >= 2  # reworded, differently per episode


BIN = Path(sys.executable).parent


@pytest.mark.slow
@pytest.mark.subprocess
def test_eval_against_xicm_serve_policy_and_against_nothing(tmp_path):
    port = free_port()
    common = ["benchmark.tasks=[push_buttons]", "episodes=2", "progress=false", f"paths.cache={tmp_path}/cache"]
    down = subprocess.run([str(BIN / "xicm-eval"), "policy=remote", f"policy.port={port}", *common, "hydra.run.dir=down"],
                          capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert down.returncode == 2 and f"no policy server answered at ws://127.0.0.1:{port}" in down.stderr
    assert not (tmp_path / "down" / "episodes.jsonl").exists()

    server = subprocess.Popen([str(BIN / "xicm-serve-policy"), "policy=oracle", f"serve.port={port}", "simulator.image_size=32"],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=tmp_path)
    try:
        wait_for_serving(server, "oracle")
        served = subprocess.run([str(BIN / "xicm-eval"), "policy=remote", f"policy.port={port}", *common, "hydra.run.dir=served"],
                                capture_output=True, text=True, cwd=tmp_path, timeout=600)
        assert served.returncode == 0, served.stderr[-3000:]
    finally:
        server.terminate()
        server.wait(timeout=30)
    local = subprocess.run([str(BIN / "xicm-eval"), "policy=oracle", *common, "hydra.run.dir=local"],
                           capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert local.returncode == 0, local.stderr[-3000:]

    import json

    def rows(run):
        return [{k: r[k] for k in ("task", "seed", "episode", "success", "steps", "error_kind")}
                for r in map(json.loads, (tmp_path / run / "episodes.jsonl").read_text().splitlines())]

    assert rows("served") == rows("local") and all(r["success"] for r in rows("local"))


def test_a_whole_observation_survives_the_wire(sim):
    from xicm.serving.observation import observation_from_wire, observation_to_wire
    from xicm.serving.wire import pack, unpack

    obs = sim.reset(TASK, 0, 0)
    back = observation_from_wire(unpack(pack(observation_to_wire(obs))))
    assert (back.instruction, back.object_names, back.segment_names, back.gripper) == (
        obs.instruction, obs.object_names, obs.segment_names, obs.gripper)
    assert set(back.cameras) == set(obs.cameras)
    for name, frame in obs.cameras.items():
        for field in ("rgb", "depth", "segmentation", "intrinsic", "cam_to_world"):
            mine, theirs = getattr(frame, field), getattr(back.cameras[name], field)
            if mine is None:
                assert theirs is None
            else:
                assert theirs.dtype == mine.dtype and np.array_equal(theirs, mine), (name, field)
    assert set(back.proprio) == set(obs.proprio) and all(np.array_equal(back.proprio[k], obs.proprio[k]) for k in obs.proprio)
    np.testing.assert_array_equal(back.joint_positions, obs.joint_positions)


def test_an_image_mapping_on_the_command_line_replaces_the_default_whole():
    """docs/guides/vla-evaluation.md's commands map two cameras on the command line; Hydra would refuse a new key
    merged into a default mapping, and a merge would keep a camera the user left out."""
    from hydra import compose, initialize_config_module

    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        two = compose("config", overrides=["policy=remote", "policy.images={front: observation.images.front, wrist: observation.images.wrist}"])
        wrist_only = compose("config", overrides=["policy=remote", "policy.images={wrist: observation/wrist_image}"])
    assert dict(two.policy.images) == {"front": "observation.images.front", "wrist": "observation.images.wrist"}
    assert dict(wrist_only.policy.images) == {"wrist": "observation/wrist_image"}


@pytest.mark.parametrize(
    "options, words",
    [
        ({"control_mode": "pd_ee_delta_pose"}, "policy.control_mode is 'pd_ee_delta_pose'; the simulator's control modes are ee_delta, ee_pose,"),
        ({"state_key": "observation/state", "state": ["joint_velocities"]}, "policy.state names joint_velocities; the simulator's proprio fields are joint_positions,"),
    ],
)
def test_a_control_mode_or_state_field_the_simulator_does_not_declare_is_one_sentence(sim, options, words):
    from xicm.core.contracts.errors import ConfigError

    server = PolicyServer(Replies(), port=0).start()
    try:
        with pytest.raises(ConfigError) as err:
            remote(server.port, sim.control_spec(), **options)
        assert str(err.value).startswith(words) and "\n" not in str(err.value)
    finally:
        server.stop()
