"""The policy-server dialect: msgpack-numpy frames, a real server and client on 127.0.0.1."""

import time
import urllib.request

import numpy as np
import pytest

from xicm.serving.client import PolicyClient, ServerError, server_uri
from xicm.serving.ports import free_port
from xicm.serving.server import PolicyServer
from xicm.serving.wire import pack, unpack


def test_arrays_and_scalars_round_trip_with_dtype_and_shape():
    obs = {
        "observation/image": np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3),
        "observation/state": np.linspace(-1, 1, 8, dtype=np.float32),
        "nested": [np.int64(7), {"x": np.float32(0.25)}],
        "prompt": "close the box",
        "empty": np.zeros((0, 7)),
    }
    back = unpack(pack(obs))
    assert back["observation/image"].dtype == np.uint8 and back["observation/image"].shape == (2, 3, 3)
    np.testing.assert_array_equal(back["observation/image"], obs["observation/image"])
    np.testing.assert_array_equal(back["observation/state"], obs["observation/state"])
    assert back["nested"][0] == 7 and isinstance(back["nested"][0], np.int64)
    assert back["nested"][1]["x"] == 0.25 and isinstance(back["nested"][1]["x"], np.float32)
    assert back["prompt"] == "close the box" and back["empty"].shape == (0, 7)


def test_the_map_layout_is_openpis():
    import msgpack

    raw = msgpack.unpackb(pack({"a": np.array([1.5], dtype="<f4")}), raw=False)
    assert raw["a"] == {b"__ndarray__": True, b"data": np.array([1.5], dtype="<f4").tobytes(), b"dtype": "<f4", b"shape": [1]}


def test_object_arrays_are_refused():
    with pytest.raises(TypeError, match="dtype object"):
        pack({"bad": np.array([object()])})


class Doubler:
    def infer(self, obs):
        if "boom" in obs:
            raise ValueError("the state has 3 values, expected 8")
        if "sleep" in obs:
            time.sleep(float(obs["sleep"]))
        return {"actions": np.asarray(obs["state"]) * 2}


@pytest.fixture()
def server():
    srv = PolicyServer(Doubler(), host="127.0.0.1", port=0, metadata={"action_dim": 8}).start()
    yield srv
    srv.stop()


def test_client_gets_metadata_and_replies(server):
    client = PolicyClient(server_uri("127.0.0.1", server.port), timeout_s=10)
    assert client.connect() == {"action_dim": 8}
    reply = client.infer({"state": np.ones(8, dtype=np.float32)})
    np.testing.assert_array_equal(reply["actions"], np.full(8, 2, dtype=np.float32))
    client.close()


def test_health_check_answers_200_ok(server):
    with urllib.request.urlopen(f"http://127.0.0.1:{server.port}/healthz", timeout=10) as resp:
        assert resp.status == 200 and resp.read() == b"OK\n"


def test_a_failing_infer_is_one_sentence_and_the_connection_goes_on(server):
    client = PolicyClient(server_uri("127.0.0.1", server.port), timeout_s=10)
    with pytest.raises(ServerError, match="the state has 3 values") as err:
        client.infer({"boom": 1})
    assert err.value.kind == "server_error"
    np.testing.assert_array_equal(client.infer({"state": np.ones(2)})["actions"], [2.0, 2.0])


def test_a_slow_server_times_out_and_the_next_request_is_answered_fresh(server):
    client = PolicyClient(server_uri("127.0.0.1", server.port), timeout_s=0.5)
    with pytest.raises(ServerError, match="did not answer within 0.5 s") as err:
        client.infer({"sleep": 1.5, "state": np.ones(1)})
    assert err.value.kind == "server_timeout"
    time.sleep(1.2)  # the server finishes the slow request on the dropped connection
    np.testing.assert_array_equal(client.infer({"state": np.full(1, 3.0)})["actions"], [6.0])


def test_a_connection_the_server_closed_while_idle_is_reopened_for_the_next_request():
    """A restarted server (or one that dropped an idle client) costs no episode: the request was
    never sent on the closed connection, so the client reconnects and sends it."""
    first = PolicyServer(Doubler(), host="127.0.0.1", port=0).start()
    port = first.port
    client = PolicyClient(server_uri("127.0.0.1", port), timeout_s=10)
    np.testing.assert_array_equal(client.infer({"state": np.ones(1)})["actions"], [2.0])
    first.stop()
    second = PolicyServer(Doubler(), host="127.0.0.1", port=port).start()
    try:
        deadline = time.monotonic() + 10
        while client._ws.state.name == "OPEN" and time.monotonic() < deadline:  # the close frame arrives
            time.sleep(0.05)
        np.testing.assert_array_equal(client.infer({"state": np.full(1, 4.0)})["actions"], [8.0])
    finally:
        client.close()
        second.stop()


def test_nothing_listening_is_unreachable_in_one_sentence():
    port = free_port()  # free a moment ago: no server listens there
    with pytest.raises(ServerError, match=f"no policy server answered at ws://127.0.0.1:{port}") as err:
        PolicyClient(server_uri("127.0.0.1", port), timeout_s=2).connect()
    assert err.value.kind == "server_unreachable"
