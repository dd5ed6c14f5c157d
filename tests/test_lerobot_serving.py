"""A LeRobot policy served by xicm-serve-lerobot (in the lerobot environment) answers with the
same actions as the policy in memory, and xicm-eval policy=remote runs episodes against it."""

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

from xicm.lerobot.env import env_python
from xicm.serving.client import PolicyClient, ServerError, server_uri
from xicm.lerobot.serve import start

pytestmark = [pytest.mark.slow, pytest.mark.venv, pytest.mark.subprocess]
CACHE = Path(os.environ.get("XICM_CACHE", Path.home() / ".cache" / "xicm")).expanduser()


@pytest.fixture(scope="module")
def tiny_act(tmp_path_factory):
    """A tiny random ACT checkpoint (32 px front camera, 16-D state, 8-D joint_pos actions) and
    the chunk the in-memory policy predicted for a fixed observation."""
    python = env_python(CACHE)
    folder = tmp_path_factory.mktemp("act")
    done = subprocess.run([str(python), str(Path(__file__).with_name("lerobot_tiny_act.py")), str(folder / "ckpt"), str(folder / "ref.npz")],
                          capture_output=True, text=True, timeout=600, env={**os.environ, "HF_HUB_OFFLINE": "1"})
    assert done.returncode == 0, done.stderr[-3000:]
    return python, folder / "ckpt", np.load(folder / "ref.npz")


def served_port(server: subprocess.Popen) -> int:
    """The port a LeRobot server started with --port 0 says it serves on."""
    for line in server.stdout:
        if "serving act" in line:
            return int(line.rsplit(":", 1)[1])
    pytest.fail("the LeRobot server exited before serving")


def serve(tiny_act, max_batch: int = 1):
    python, ckpt, _ = tiny_act
    server = start(python, CACHE, str(ckpt), port=0, control_mode="joint_pos", max_batch=max_batch,
                   stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        yield served_port(server)
    finally:
        server.terminate()
        server.wait(timeout=30)


@pytest.fixture(scope="module")
def served(tiny_act):
    yield from serve(tiny_act)


def test_served_actions_are_the_in_memory_policys(tiny_act, served):
    _, _, ref = tiny_act
    client = PolicyClient(server_uri("127.0.0.1", served), timeout_s=60)
    meta = client.connect()
    assert meta["lerobot"]["policy_type"] == "act" and meta["xicm"]["control_mode"] == "joint_pos"
    reply = client.infer({"observation.images.front": ref["image"], "observation.state": ref["state"], "task": "push the button"})
    assert reply["actions"].shape == (5, 8)
    np.testing.assert_array_equal(reply["actions"], ref["chunk"].astype(np.float64))


def test_xicm_eval_runs_episodes_against_the_served_policy(served, tmp_path):
    import json
    import sys

    args = [
        str(Path(sys.executable).parent / "xicm-eval"), "policy=remote", f"policy.port={served}", "policy.timeout_s=60",
        "policy.images={front: observation.images.front}", "policy.state_key=observation.state",
        "policy.state=[joint_positions,gripper_width,tcp_pose,gripper_open]", "policy.prompt_key=task",
        "simulator.image_size=32", "simulator.cameras=[front]", "simulator.control_mode=joint_pos",
        "benchmark.tasks=[push_buttons]", "episodes=2", "max_control_steps=6", "progress=false", "hydra.run.dir=run",
    ]
    out = subprocess.run(args, capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    rows = [json.loads(line) for line in (tmp_path / "run" / "episodes.jsonl").read_text().splitlines()]
    # a random policy: each episode runs its 6 control steps (5 + 1 of a second chunk) and fails,
    # or stops early on an unreachable joint target; never a wire or shape error
    assert len(rows) == 2 and all(r["error_kind"] in ("max_control_steps", "unreachable") for r in rows), rows
    assert all(r["steps"] >= 1 for r in rows)


def test_batched_requests_get_the_one_at_a_time_chunks(tiny_act, served):
    """--max-batch 2: two connections asking together share one forward pass; each chunk is the
    one the one-at-a-time server gives for that observation (to float32 rounding of a batched matmul)."""
    from test_server_batching import ask_together

    _, _, ref = tiny_act
    other = {"observation.images.front": ref["image"][::-1].copy(), "observation.state": -ref["state"], "task": "push the button"}
    first = {"observation.images.front": ref["image"], "observation.state": ref["state"], "task": "push the button"}
    alone = ask_together(served, [other])[0]["actions"]
    for port in serve(tiny_act, max_batch=2):
        together = ask_together(port, [first, other])
    np.testing.assert_allclose(together[0]["actions"], ref["chunk"].astype(np.float64), rtol=0, atol=1e-5)
    np.testing.assert_allclose(together[1]["actions"], alone, rtol=0, atol=1e-5)
    assert not np.allclose(together[0]["actions"], together[1]["actions"])  # two different answers, not one copied


def test_stopping_xicm_serve_lerobot_stops_the_server_itself(tiny_act):
    """The command becomes the server process: killing the PID a user started (`... &`, then
    `kill %1`) frees the port instead of leaving a server orphaned on it."""
    import signal
    import sys

    _, ckpt, _ = tiny_act
    cmd = [str(Path(sys.executable).parent / "xicm-serve-lerobot"), str(ckpt), "--port", "0", "--cache", str(CACHE)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        port = served_port(proc)
        PolicyClient(server_uri("127.0.0.1", port), timeout_s=30).connect()  # it serves
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=30)
        with pytest.raises(ServerError) as err:
            PolicyClient(server_uri("127.0.0.1", port), timeout_s=5).connect()
        assert err.value.kind == "server_unreachable"
    finally:
        proc.kill()
        proc.wait(timeout=30)



def test_a_keyed_lerobot_server_refuses_a_missing_key_and_a_client_over_its_cap(tiny_act, monkeypatch):
    """xicm-serve-lerobot's --api-key-env and --max-sessions reach the server in the lerobot
    environment; the key itself travels in the environment only, never on a command line."""
    import secrets

    python, ckpt, ref = tiny_act
    key = secrets.token_hex(16)
    monkeypatch.setenv("XICM_TEST_LEROBOT_KEY", key)
    server = start(python, CACHE, str(ckpt), port=0, control_mode="joint_pos", stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                   text=True, limits=("--api-key-env", "XICM_TEST_LEROBOT_KEY", "--max-sessions", "1"))
    try:
        assert key not in " ".join(server.args)
        uri = server_uri("127.0.0.1", served_port(server))
        with pytest.raises(ServerError, match="HTTP 401") as err:
            PolicyClient(uri, timeout_s=60).connect()
        assert err.value.kind == "server_refused"
        client = PolicyClient(uri, timeout_s=60, api_key=key)
        reply = client.infer({"observation.images.front": ref["image"], "observation.state": ref["state"], "task": "push the button"})
        np.testing.assert_array_equal(reply["actions"], ref["chunk"].astype(np.float64))
        with pytest.raises(ServerError, match="at its cap of 1 sessions"):
            PolicyClient(uri, timeout_s=60, api_key=key).connect()
        client.close()
    finally:
        server.terminate()
        out = server.communicate(timeout=30)[0]
    assert key not in out and "refused" in out
