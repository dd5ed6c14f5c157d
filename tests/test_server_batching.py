"""Server-side batching over real websockets on 127.0.0.1: concurrent requests from several
connections are answered by one infer_batch call, each with its own reply; a bad request in a
batch gets its own error and the others their replies."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from xicm.serving.client import PolicyClient, ServerError, server_uri
from xicm.serving.server import PolicyServer


class Doubler:
    """Stateless: actions = 2 * the request's value; records the size of every batch call."""

    def __init__(self):
        self.batch_calls: list[int] = []

    def infer(self, obs: dict) -> dict:
        return self.infer_batch([obs])[0]

    def infer_batch(self, observations: list[dict]) -> list[dict]:
        self.batch_calls.append(len(observations))
        if any("value" not in obs for obs in observations):
            raise KeyError("the request has no 'value'")
        return [{"actions": np.full((2, 3), 2.0 * obs["value"])} for obs in observations]


def ask_together(port: int, requests: list[dict]) -> list:
    """One connection per request, all sent at once (as envs=N lockstep does); replies or errors."""
    clients = [PolicyClient(server_uri("127.0.0.1", port), timeout_s=10) for _ in requests]
    for client in clients:
        client.connect()
    results: list = [None] * len(requests)
    start = threading.Barrier(len(requests))

    def ask(i: int) -> None:
        start.wait()
        try:
            results[i] = clients[i].infer(requests[i])
        except ServerError as exc:
            results[i] = exc

    threads = [threading.Thread(target=ask, args=(i,)) for i in range(len(requests))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for client in clients:
        client.close()
    return results


def test_concurrent_requests_are_answered_in_one_batch_each_with_its_own_reply():
    policy = Doubler()
    server = PolicyServer(policy, port=0, max_batch=4, batch_wait_ms=200).start()
    try:
        replies = ask_together(server.port, [{"value": float(i)} for i in range(4)])
    finally:
        server.stop()
    assert [float(r["actions"][0, 0]) for r in replies] == [0.0, 2.0, 4.0, 6.0]
    assert policy.batch_calls == [4]
    assert server.batcher.batch_sizes == [4]


def test_a_bad_request_in_a_batch_fails_alone():
    policy = Doubler()
    server = PolicyServer(policy, port=0, max_batch=3, batch_wait_ms=200).start()
    try:
        replies = ask_together(server.port, [{"value": 1.0}, {"other": 0}, {"value": 3.0}])
    finally:
        server.stop()
    assert float(replies[0]["actions"][0, 0]) == 2.0 and float(replies[2]["actions"][0, 0]) == 6.0
    assert isinstance(replies[1], ServerError) and replies[1].kind == "server_error"
    assert "no 'value'" in str(replies[1])
    assert policy.batch_calls[0] == 3 and sorted(policy.batch_calls[1:]) == [1, 1, 1]  # then one by one


def test_batching_needs_a_stateless_policy_with_infer_batch():
    class OneAtATime:
        def infer(self, obs):
            return {"actions": np.zeros((1, 1))}

    with pytest.raises(ValueError, match="max_batch=2 needs a stateless policy with infer_batch; OneAtATime"):
        PolicyServer(OneAtATime(), port=0, max_batch=2)
