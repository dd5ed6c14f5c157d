"""Keys for serving: read from environment variables only, sent as openpi-client's
`Authorization: Api-Key <key>`, checked by our servers at the websocket handshake; a key given as
a config value is refused, and none reaches a file a run writes (real servers on 127.0.0.1)."""

import logging
import os
import secrets
import subprocess
import sys
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from xicm.core.contracts.errors import ConfigError
from xicm.core.assembly.literal_keys import refuse_literal_keys, refuse_literal_keys_on_command_line
from xicm.serving.client import PolicyClient, ServerError, server_uri
from xicm.serving.keys import KeyNotSet, key_from_env, key_matches
from xicm.serving.ports import free_port, start_server
from xicm.serving.server import PolicyServer

BIN = Path(sys.executable).parent


class Doubler:
    def __init__(self):
        self.calls = 0

    def infer(self, obs):
        self.calls += 1
        return {"actions": np.asarray(obs["state"]) * 2}


@pytest.fixture()
def keyed():
    key = secrets.token_hex(16)
    policy = Doubler()
    srv = PolicyServer(policy, host="127.0.0.1", port=0, metadata={"action_dim": 1}, api_key=key).start()
    yield srv, key, policy
    srv.stop()


def test_the_right_key_is_served_and_a_missing_or_wrong_one_is_refused_at_the_handshake(keyed):
    srv, key, policy = keyed
    uri = server_uri("127.0.0.1", srv.port)
    client = PolicyClient(uri, timeout_s=10, api_key=key)
    try:
        assert client.connect() == {"action_dim": 1}
        np.testing.assert_array_equal(client.infer({"state": np.ones(1)})["actions"], [2.0])
    finally:
        client.close()
    for sent, status, words in ((None, 401, "this server needs a key"), (key[:-1] + "x", 403, "key sent in the Authorization header is wrong"),
                                ("", 401, "needs a key"), (key + key, 403, "wrong")):
        with pytest.raises(ServerError, match=words) as err:
            PolicyClient(uri, timeout_s=10, api_key=sent).infer({"state": np.ones(1)})
        assert err.value.kind == "server_refused" and err.value.status == status
        assert f"refused the connection with HTTP {status}" in str(err.value) and key not in str(err.value)
    assert policy.calls == 1  # no refused request reached the policy


def test_healthz_needs_no_key(keyed):
    srv, _, _ = keyed
    with urllib.request.urlopen(f"http://127.0.0.1:{srv.port}/healthz", timeout=10) as resp:
        assert resp.status == 200 and resp.read() == b"OK\n"


def test_two_authorization_headers_are_refused(keyed):
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect

    srv, key, _ = keyed
    with pytest.raises(InvalidStatus) as err:
        connect(server_uri("127.0.0.1", srv.port), open_timeout=10,
                additional_headers=[("Authorization", f"Api-Key {key}"), ("Authorization", "Api-Key other")])
    assert err.value.response.status_code == 403


def test_keys_compare_whole_headers_in_the_openpi_form():
    assert key_matches("Api-Key s3cret", "s3cret")
    for header in (None, "", "s3cret", "Bearer s3cret", "api-key s3cret", "Api-Key s3cre", "Api-Key s3cret ", "Api-Key s3cretX", "Api-Key \udcff"):
        assert not key_matches(header, "s3cret"), header


def test_serving_beyond_this_machine_without_a_key_warns(caplog):
    caplog.set_level(logging.WARNING, logger="xicm.serving.server")
    for host, warned in (("127.0.0.1", False), ("localhost", False), ("0.0.0.0", True)):
        caplog.clear()
        srv = PolicyServer(Doubler(), host=host, port=0, key_setting="serve.api_key_env").start()
        srv.stop()
        words = [r.getMessage() for r in caplog.records if "without a key" in r.getMessage()]
        assert bool(words) == warned, (host, words)
        if warned:
            assert "serving on 0.0.0.0 without a key" in words[0] and "serve.api_key_env" in words[0]
    caplog.clear()
    PolicyServer(Doubler(), host="0.0.0.0", port=0, api_key="k").start().stop()
    assert not [r for r in caplog.records if "without a key" in r.getMessage()]


def test_a_key_comes_from_the_named_variable_and_an_unset_one_is_one_sentence(monkeypatch):
    monkeypatch.setenv("XICM_TEST_KEY", "abc")
    assert key_from_env("XICM_TEST_KEY", "policy.api_key_env") == "abc"
    assert key_from_env(None, "policy.api_key_env") is None
    monkeypatch.setenv("XICM_TEST_KEY", " ")
    monkeypatch.delenv("XICM_TEST_UNSET", raising=False)
    for name in ("XICM_TEST_KEY", "XICM_TEST_UNSET"):
        with pytest.raises(KeyNotSet, match=f"policy.api_key_env names the environment variable {name}, which is not set or is empty"):
            key_from_env(name, "policy.api_key_env")


@pytest.mark.parametrize("arg", ["policy.api_key=abc", "+policy.api_key=abc", "++llm.api_key='abc'", "serve.api_key=abc,def", "api_key=abc"])
def test_a_key_on_the_command_line_is_refused_without_repeating_it(arg):
    with pytest.raises(ConfigError, match=r"api_key is refused: a key in the config is written to run.json") as err:
        refuse_literal_keys_on_command_line(["episodes=1", arg])
    assert "abc" not in str(err.value) and "api_key_env" in str(err.value)


def test_what_the_literal_key_check_leaves_alone():
    refuse_literal_keys_on_command_line(["policy.api_key=null", "~policy.api_key", "policy.api_key_env=MY_KEY", "-m", "hydra.x.api_key=1"])
    refuse_literal_keys({"policy": {"api_key_env": "X", "api_key": None}, "llm": {"name": "openai_compatible"}})
    with pytest.raises(ConfigError, match=r"^llm.api_key is refused.* set llm.api_key_env to that variable's name$"):
        refuse_literal_keys({"policy": {}, "llm": {"api_key": "abc"}})


def test_xicm_eval_refuses_a_key_on_the_command_line_before_hydra_writes_anything(tmp_path):
    key = secrets.token_hex(8)
    out = subprocess.run([str(BIN / "xicm-eval"), "policy=remote", f"policy.api_key={key}", "hydra.run.dir=run"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert out.returncode == 2 and out.stderr.strip().startswith("xicm: error: policy.api_key is refused")
    assert key not in out.stderr + out.stdout and not (tmp_path / "run").exists()


def files_holding(folder: Path, needle: str) -> list[str]:
    """Every file under `folder` whose bytes contain `needle` (binary files too: wandb's .wandb log)."""
    return [str(p.relative_to(folder)) for p in sorted(folder.rglob("*")) if p.is_file() and needle.encode() in p.read_bytes()]


@pytest.mark.slow
@pytest.mark.subprocess
def test_a_keyed_xicm_serve_policy_and_xicm_eval_leave_the_key_in_no_file(tmp_path):
    """A real server and evaluation with the key in the environment only, tracked by an offline
    wandb run: the key is in none of the run's files; a wrong or missing key stops xicm-eval at
    start with one sentence."""
    key = "xicm-test-key-" + secrets.token_hex(12)
    port = free_port()
    env = {k: v for k, v in os.environ.items() if k != "WANDB_MODE"}  # conftest disables wandb
    server, server_lines = start_server([str(BIN / "xicm-serve-policy"), "policy=oracle", f"serve.port={port}", "simulator.image_size=32",
                                         "serve.api_key_env=XICM_SERVE_KEY"], "serving policy 'oracle'", cwd=tmp_path,
                                        env={**env, "XICM_SERVE_KEY": key})
    common = [str(BIN / "xicm-eval"), "policy=remote", f"policy.port={port}", "benchmark.tasks=[push_buttons]", "episodes=1",
              "progress=false", f"paths.cache={tmp_path}/cache", "policy.api_key_env=XICM_POLICY_KEY"]
    try:
        run = subprocess.run([*common, "tracking.mode=offline", "hydra.run.dir=run"], capture_output=True, text=True, cwd=tmp_path,
                             timeout=600, env={**env, "XICM_POLICY_KEY": key})
        assert run.returncode == 0, run.stderr[-3000:]
        wrong = subprocess.run([*common, "hydra.run.dir=wrong"], capture_output=True, text=True, cwd=tmp_path, timeout=600,
                               env={**env, "XICM_POLICY_KEY": "not-" + key})
        unset = subprocess.run([*common, "hydra.run.dir=unset"], capture_output=True, text=True, cwd=tmp_path, timeout=600, env=env)
    finally:
        server.terminate()
        server.wait(timeout=60)
    server_out = "".join(server_lines)
    assert wrong.returncode == 2, wrong.stderr[-2000:]
    assert wrong.stderr.strip().splitlines()[-1] == (
        f"xicm: error: the policy server at ws://127.0.0.1:{port} refused the connection with HTTP 403 "
        "(the key sent in the Authorization header is wrong): check the key in $XICM_POLICY_KEY (policy.api_key_env)")
    assert unset.returncode == 2 and unset.stderr.strip().splitlines()[-1] == (
        "xicm: error: policy.api_key_env names the environment variable XICM_POLICY_KEY, which is not set or is empty")
    folder = tmp_path / "run"
    written = {p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()}
    assert {"run.json", "episodes.jsonl", ".hydra/config.yaml", ".hydra/overrides.yaml", ".hydra/hydra.yaml"} <= written, written
    assert any(w.startswith("wandb/offline-run-") and w.endswith(".wandb") for w in written), written
    assert "XICM_POLICY_KEY" in (folder / ".hydra" / "config.yaml").read_text()  # the variable's name is kept, not its value
    assert files_holding(tmp_path, key) == []
    assert key not in run.stdout + run.stderr + wrong.stderr + server_out
    assert "refused" in server_out and "wrong key" in server_out


@pytest.mark.parametrize("host, refused", [("ws://user:secret@gpu:8000", True), ("wss://k@gpu", True), ("gpu.local", False),
                                           ("ws://gpu:8000/path@x", False)])
def test_credentials_in_the_policy_host_are_refused_without_repeating_them(host, refused):
    from omegaconf import OmegaConf

    from xicm.plugins.policies.remote import check_remote_config

    cfg = OmegaConf.create({"policy": {"host": host, "gripper_open": 1.0, "gripper_closed": 0.0}})
    if not refused:
        check_remote_config(cfg, None)
        return
    with pytest.raises(ConfigError, match=r"^policy.host must not hold credentials") as err:
        check_remote_config(cfg, None)
    assert "secret" not in str(err.value) and "k@" not in str(err.value)
