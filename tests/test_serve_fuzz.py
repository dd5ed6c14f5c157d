"""Malformed frames on real sockets (127.0.0.1): a live xicm-serve-policy answers every one of more
than 10,000 with an error frame while a good client's episode goes on, and a PolicyClient facing a
server that replies with them raises only ServerError. The frames are test_wire_decode.py's
fuzz_frames plus every dtype letter, lying and huge shapes, and deep nesting."""

import collections
import os
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from test_wire_decode import LETTERS, array_map, deep_frame, frame, fuzz_frames, nested
from websockets.sync.client import connect
from websockets.sync.server import serve

from xicm.serving.client import PolicyClient, ServerError, server_uri
from xicm.serving.ports import free_port, start_server
from xicm.serving.wire import pack

BIN = Path(sys.executable).parent
FUZZ_KINDS = ("random bytes", "changed bytes", "array map", "cut or padded")  # fuzz_frames' kinds, in turn


def crafted_frames():
    """(kind, frame) pairs: fuzz_frames' 12,000 and the shapes and dtypes they draw from a short list."""
    for i, raw in enumerate(fuzz_frames()):
        yield FUZZ_KINDS[i % 4], raw
    for letter in LETTERS:  # every dtype letter numpy knows, with matching and lying byte counts
        size = np.dtype(letter).itemsize or 1
        for shape, data in (([3], b"\x01" * 3 * size), ([3], b"\x01" * (3 * size + 1)), ([2, 2], b"")):
            yield "dtype letter", frame({"state": array_map(np.dtype(letter).str, shape, data)})
    for shape in ([2**31, 2**31], [2**62], [0, 2**62], [1] * 33, [2**16, 2**16, 3], [-1]):
        yield "huge or bad shape", frame({"state": array_map("|u1", shape, b"\x00" * 8)})
    for depth in (33, 100, 1000, 5000):
        yield "deep nesting", deep_frame(depth)
        yield "deep nesting", frame(nested(min(depth, 400)))


def ask_episode(uri: str, key: str, stop: threading.Event, answers: list) -> None:
    """A good client: the first call of episode after episode of the served oracle, each answered with actions."""
    client = PolicyClient(uri, timeout_s=120, api_key=key)
    episode = 0
    try:
        while not stop.is_set():
            reply = client.infer({"xicm/episode": {"task": "push_buttons", "seed": 0, "episode": episode % 3, "call": 0}})
            answers.append("actions" in reply and "xicm/failure" not in reply)
            episode += 1
    except Exception as exc:  # noqa: BLE001 - recorded: the test fails on it
        answers.append(exc)
    finally:
        client.close()


@pytest.mark.slow
@pytest.mark.subprocess
def test_a_live_served_policy_answers_every_malformed_frame_and_a_good_client_throughout(tmp_path):
    key = "fuzz-key"
    port = free_port()
    server, _ = start_server([str(BIN / "xicm-serve-policy"), "policy=oracle", f"serve.port={port}", "simulator.image_size=32",
                              "serve.sessions=2", "serve.api_key_env=XICM_FUZZ_KEY", "benchmark.tasks=[push_buttons]"],
                             "serving policy 'oracle'", cwd=tmp_path, env={**os.environ, "XICM_FUZZ_KEY": key})
    uri = server_uri("127.0.0.1", port)
    try:
        stop, answers = threading.Event(), []
        good = threading.Thread(target=ask_episode, args=(uri, key, stop, answers))
        good.start()
        sent, errors, replies = collections.Counter(), collections.Counter(), collections.Counter()
        start = time.monotonic()
        with connect(uri, compression=None, open_timeout=60, additional_headers={"Authorization": f"Api-Key {key}"}) as ws:
            ws.recv(timeout=60)  # metadata
            for kind, raw in crafted_frames():
                ws.send(raw)
                answer = ws.recv(timeout=120)  # a closed connection or a dead server raises here
                sent[kind] += 1
                (errors if isinstance(answer, str) else replies)[kind] += 1
        fuzz_s = time.monotonic() - start
        stop.set()
        good.join(timeout=300)
        assert server.poll() is None, "the server died"
    finally:
        server.terminate()
        server.wait(timeout=60)
    print(f"\n{sum(sent.values())} frames in {fuzz_s:.1f} s; per kind (sent / error frames / replies):")
    for kind in sent:
        print(f"  {kind}: {sent[kind]} / {errors[kind]} / {replies[kind]}")
    print(f"good client: {len(answers)} answers, {sum(a is True for a in answers)} with actions")
    assert sum(sent.values()) >= 10_000 and set(sent) == {*FUZZ_KINDS, "dtype letter", "huge or bad shape", "deep nesting"}
    assert errors["deep nesting"] == sent["deep nesting"] and errors["huge or bad shape"] == sent["huge or bad shape"]
    assert len(answers) >= 3 and all(a is True for a in answers), answers[-3:]


def test_a_client_facing_a_server_that_replies_with_malformed_frames_raises_only_server_error():
    """Every crafted frame as the reply of a real websocket server: PolicyClient.infer returns a
    map or raises ServerError with one sentence; then a good reply is still read in step."""
    frames = [raw for _, raw in crafted_frames()]
    good = pack({"actions": np.ones((1, 8))})

    def reply_with_frames(ws):
        ws.send(pack({"action_dim": 8}))
        for raw in frames + [good]:
            ws.recv()
            ws.send(raw)

    outcomes = collections.Counter()
    with serve(reply_with_frames, "127.0.0.1", 0, compression=None) as evil:
        threading.Thread(target=evil.serve_forever, daemon=True).start()
        client = PolicyClient(server_uri("127.0.0.1", evil.socket.getsockname()[1]), timeout_s=10)
        try:
            for _ in frames:
                try:
                    client.infer({"state": np.ones(1)})
                except ServerError as exc:
                    assert exc.kind == "bad_reply" and str(exc), exc
                    outcomes["bad_reply"] += 1
                else:
                    outcomes["decoded"] += 1
            np.testing.assert_array_equal(client.infer({"state": np.ones(1)})["actions"], np.ones((1, 8)))
        finally:
            client.close()
            evil.shutdown()
    print(f"\n{len(frames)} malformed replies: {dict(outcomes)}")
    assert sum(outcomes.values()) == len(frames) >= 10_000 and outcomes["bad_reply"] > len(frames) // 2
