"""Server limits on real sockets (127.0.0.1): a cap on sessions, an idle timeout, and clients that
leave mid-episode handing back their session and its simulator process (no process or port leak)."""

import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from omegaconf import OmegaConf
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

import xicm
from xicm.serving import limits
from xicm.serving.client import PolicyClient, ServerError, server_uri
from xicm.serving.ports import free_port, server_counts, start_server
from xicm.serving.server import PolicyServer
from xicm.serving.wire import pack, unpack

BIN = Path(sys.executable).parent


def wait_until(condition, timeout_s: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


class Doubler:
    def infer(self, obs):
        return {"actions": np.asarray(obs["state"]) * 2}


def test_the_configs_limits_are_the_servings_defaults():
    serve = OmegaConf.load(Path(xicm.__file__).parent / "conf" / "config.yaml").serve
    assert serve.max_sessions == limits.MAX_SESSIONS and serve.idle_timeout_s == limits.IDLE_TIMEOUT_S
    assert serve.api_key_env is None


def test_a_client_over_the_cap_is_refused_with_the_reason_and_served_once_a_session_frees():
    srv = PolicyServer(Doubler(), port=0, max_sessions=2).start()
    uri = server_uri("127.0.0.1", srv.port)
    first, second = PolicyClient(uri, timeout_s=10), PolicyClient(uri, timeout_s=10)
    try:
        for client in (first, second):
            np.testing.assert_array_equal(client.infer({"state": np.ones(1)})["actions"], [2.0])
        with pytest.raises(ServerError, match=r"refused the connection \(the server is at its cap of 2 sessions; try again later\)") as err:
            PolicyClient(uri, timeout_s=10).connect()
        assert err.value.kind == "server_refused" and srv.active == 2
        second.close()
        assert wait_until(lambda: srv.active == 1)  # the server sees the close
        third = PolicyClient(uri, timeout_s=10)
        np.testing.assert_array_equal(third.infer({"state": np.full(1, 3.0)})["actions"], [6.0])
        third.close()
        np.testing.assert_array_equal(first.infer({"state": np.ones(1)})["actions"], [2.0])  # the first went on throughout
    finally:
        first.close()
        second.close()
        srv.stop()


def test_a_silent_client_is_disconnected_and_a_busy_one_is_not():
    srv = PolicyServer(Doubler(), port=0, idle_timeout_s=0.5).start()
    uri = server_uri("127.0.0.1", srv.port)
    try:
        with connect(uri, compression=None, open_timeout=10) as busy, connect(uri, compression=None, open_timeout=10) as silent:
            busy.recv(timeout=10)
            silent.recv(timeout=10)
            start = time.monotonic()
            for _ in range(12):  # 1.2 s of requests 0.1 s apart: never idle for 0.5 s
                busy.send(pack({"state": np.ones(1)}))
                assert unpack(busy.recv(timeout=10))["actions"][0] == 2.0
                time.sleep(0.1)
            with pytest.raises(ConnectionClosed) as closed:
                silent.recv(timeout=10)
            assert closed.value.rcvd.code == 1000 and closed.value.rcvd.reason == "idle for more than 0.5 s"
            assert time.monotonic() - start < 5
        assert wait_until(lambda: srv.active == 0)
        client = PolicyClient(uri, timeout_s=10)  # a PolicyClient dropped while idle reconnects by itself
        client.infer({"state": np.ones(1)})
        time.sleep(0.8)
        np.testing.assert_array_equal(client.infer({"state": np.full(1, 5.0)})["actions"], [10.0])
        client.close()
    finally:
        srv.stop()


def start_episode(uri: str, episode: int) -> None:
    """Connect, ask for the first actions of an episode and leave without waiting for them."""
    ws = connect(uri, compression=None, open_timeout=60)
    ws.recv(timeout=60)
    ws.send(pack({"xicm/episode": {"task": "push_buttons", "seed": 0, "episode": episode, "call": 0}}))
    ws.close()


@pytest.mark.slow
@pytest.mark.subprocess
def test_clients_leaving_mid_episode_leave_no_session_process_or_port_behind(tmp_path):
    """xicm-serve-policy with one session built at start: three clients at once make it build two
    more (two more simulator processes); all three leave mid-episode; then the server has what it
    had before (one simulator process, one listening port, no connection) and still serves."""
    port = free_port()
    server, _ = start_server([str(BIN / "xicm-serve-policy"), "policy=oracle", f"serve.port={port}", "simulator.image_size=32",
                              "serve.sessions=1", "serve.max_sessions=3", "benchmark.tasks=[push_buttons]"],
                             "serving policy 'oracle'", cwd=tmp_path)
    uri = server_uri("127.0.0.1", port)
    try:
        before = server_counts(server.pid, port)
        assert before["listening"] == [port] and before["open_on_port"] == 0 and before["children"] >= 1
        threads = [threading.Thread(target=start_episode, args=(uri, i)) for i in range(3)]
        for t in threads:
            t.start()
        peak = before
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline:
            now = server_counts(server.pid, port)
            peak = max(peak, now, key=lambda c: c["children"])
            if all(not t.is_alive() for t in threads) and now == before and peak["children"] == before["children"] + 2:
                break
            time.sleep(0.5)
        assert peak["children"] == before["children"] + 2, (before, peak)  # two sessions built on need ...
        assert server_counts(server.pid, port) == before  # ... and closed again when their clients left
        client = PolicyClient(uri, timeout_s=120)
        reply = client.infer({"xicm/episode": {"task": "push_buttons", "seed": 0, "episode": 0, "call": 0}})
        assert "actions" in reply and "xicm/failure" not in reply
        client.close()
    finally:
        server.terminate()
        server.wait(timeout=60)
