"""xicm.serving.ports: a free local port, and waiting for a server process to answer HTTP 200."""

import re
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from xicm.serving.ports import ServerNotReady, free_port, wait_http_ok


def test_a_free_port_can_be_bound_and_nothing_listens_there():
    port = free_port()
    with pytest.raises(ConnectionRefusedError):
        socket.create_connection(("127.0.0.1", port), timeout=2).close()
    with socket.socket() as s:
        s.bind(("127.0.0.1", port))


def test_waiting_returns_once_the_server_answers_200(tmp_path):
    port = free_port()
    server = subprocess.Popen([sys.executable, "-m", "http.server", str(port), "--bind", "127.0.0.1"],
                              cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        assert 0 <= wait_http_ok(f"http://127.0.0.1:{port}/", server, timeout_s=30, poll_s=0.1) < 30
        assert server.poll() is None
    finally:
        server.kill()
        server.wait()


def test_a_server_that_exits_first_is_named_with_its_exit_code():
    port = free_port()
    process = subprocess.Popen([sys.executable, "-c", "raise SystemExit(3)"])
    name = re.escape(Path(sys.executable).name)
    with pytest.raises(ServerNotReady, match=rf"^{name} exited with code 3 before http://127.0.0.1:{port}/health answered$"):
        wait_http_ok(f"http://127.0.0.1:{port}/health", process, timeout_s=30, poll_s=0.1)


def test_a_server_that_never_answers_times_out_in_one_sentence():
    port = free_port()
    process = subprocess.Popen(["sleep", "30"])
    try:
        with pytest.raises(ServerNotReady, match=rf"^sleep did not answer http://127.0.0.1:{port}/health within 1 s$"):
            wait_http_ok(f"http://127.0.0.1:{port}/health", process, timeout_s=1, poll_s=0.2)
    finally:
        process.kill()
        process.wait()
