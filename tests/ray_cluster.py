"""A real Ray cluster of several nodes on this machine, for tests: each node is a `ray start --block`
process in its own session (so its raylet, agents and actor workers share one process group that
can be killed at once, like a machine that goes away), with its own temp dir and ports.

Token authentication as Ray's own `ray start --head` turns it on: RAY_AUTH_MODE=token, the token
in RAY_AUTH_TOKEN (environment only; nothing is written to ~/.ray). Drivers joining the cluster
take `env` from here."""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from xicm.serving.ports import free_port

RAY = str(Path(sys.executable).parent / "ray")
# The GCS declares a silent node dead after period x threshold: 2 s here (Ray's defaults wait longer).
FAST_NODE_DEATH = {"health_check_period_ms": 500, "health_check_failure_threshold": 4}
OBJECT_STORE_BYTES = 80 * 1024**2  # only configs and episode rows travel through it


class RayNodes:
    """`head()` then `join()`; `kill(node)` SIGKILLs one node's processes; `close()` kills what is left
    and removes the temp dirs (call it in a `finally`)."""

    def __init__(self):
        self.env = {**os.environ, "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": secrets.token_hex(32),
                    "RAY_USAGE_STATS_ENABLED": "0"}
        self.nodes: list[subprocess.Popen] = []
        self.temp_dirs: list[str] = []
        self.address: str | None = None

    def head(self, cpus: int, resources: dict[str, float]) -> subprocess.Popen:
        port = free_port()
        self.address = f"127.0.0.1:{port}"
        return self._start(
            "--head", f"--port={port}", "--node-ip-address=127.0.0.1", f"--dashboard-port={free_port()}",
            "--include-dashboard=false",
            f"--system-config={json.dumps(FAST_NODE_DEATH)}", cpus=cpus, resources=resources)

    def join(self, node_ip: str, cpus: int, resources: dict[str, float]) -> subprocess.Popen:
        """A node with its own IP on the loopback (127.0.0.2, ...), so rows can tell the nodes apart."""
        assert self.address, "start the head first"
        return self._start(f"--address={self.address}", f"--node-ip-address={node_ip}", cpus=cpus, resources=resources)

    def _start(self, *args: str, cpus: int, resources: dict[str, float]) -> subprocess.Popen:
        temp_dir = tempfile.mkdtemp(prefix="xray", dir="/tmp")  # short: Ray's socket paths must fit 107 bytes
        self.temp_dirs.append(temp_dir)
        log = open(Path(temp_dir) / "ray_start.log", "w")
        command = [RAY, "start", "--block", *args, f"--num-cpus={cpus}", f"--resources={json.dumps(resources)}",
                   f"--temp-dir={temp_dir}", f"--object-store-memory={OBJECT_STORE_BYTES}",
                   f"--dashboard-agent-listen-port={free_port()}"]
        node = subprocess.Popen(command, env=self.env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        log.close()
        self.nodes.append(node)
        _wait_for_line(Path(temp_dir) / "ray_start.log", "Ray runtime started", node, timeout_s=120)
        return node

    def kill(self, node: subprocess.Popen) -> None:
        """SIGKILL every process of the node's session: its raylet and agents, and the actor workers the
        raylet started (each in a process group of its own, in the same session)."""
        for pid in self._session(node.pid):
            with contextlib.suppress(ProcessLookupError):  # already gone
                os.kill(pid, signal.SIGKILL)
        node.wait(timeout=30)

    @staticmethod
    def _session(sid: int) -> list[int]:
        import psutil

        found = []
        for pid in psutil.pids():
            with contextlib.suppress(OSError):  # gone meanwhile
                if os.getsid(pid) == sid:
                    found.append(pid)
        return found

    def close(self) -> list[str]:
        """Kill every node (the head last); what is left: live processes of theirs, the head's port in use."""
        for node in reversed(self.nodes):
            self.kill(node)
        deadline = time.monotonic() + 30
        while (left := self.leftovers()) and time.monotonic() < deadline:
            time.sleep(0.5)
        for temp_dir in self.temp_dirs:
            subprocess.run(["rm", "-rf", temp_dir], check=False)
        if self.address and not _can_listen(int(self.address.rpartition(":")[2])):
            left.append(f"the head's port {self.address} is still listened on")
        return left

    def files_naming_the_token(self, *more: Path) -> list[str]:
        """Files under the nodes' temp dirs (and `more`) that contain the token: there should be none."""
        token = self.env["RAY_AUTH_TOKEN"].encode()
        roots = [Path(d) for d in self.temp_dirs] + list(more)
        return [str(f) for root in roots for f in root.rglob("*") if f.is_file() and token in f.read_bytes()]

    def leftovers(self) -> list[str]:
        """Live processes of the nodes' sessions, or naming their temp dirs (zombies excepted)."""
        import psutil

        pids = {pid for node in self.nodes for pid in self._session(node.pid)}
        found = []
        for process in psutil.process_iter(["cmdline", "status"]):
            line = " ".join(process.info["cmdline"] or [])
            named = any(d in line for d in self.temp_dirs)
            if (named or process.pid in pids) and process.info["status"] != psutil.STATUS_ZOMBIE:
                found.append(f"{process.pid} {line[:200]}")
        return found


def _can_listen(port: int) -> bool:
    with socket.socket() as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # TIME_WAIT left by closed connections is fine
        try:
            s.bind(("0.0.0.0", port))
            s.listen()
        except OSError:
            return False
    return True


def _wait_for_line(path: Path, text: str, process: subprocess.Popen, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if text in path.read_text(errors="replace"):
            return
        if process.poll() is not None:
            break
        time.sleep(0.25)
    raise RuntimeError(f"`ray start` did not print {text!r}: {path.read_text(errors='replace')[-2000:]}")
