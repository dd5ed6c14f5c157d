"""Local ports for server processes (the llamacpp plugin's llama-server; servers in tests and
benchmarks): a port that is free now, waiting
until a server process answers HTTP 200 on a URL, and what a server process holds (standard
library only, but for psutil in `server_counts`)."""

from __future__ import annotations

import socket
import subprocess
import threading
import time
import urllib.request
from pathlib import Path


class ServerNotReady(RuntimeError):
    """The server process exited, or did not answer within the time limit."""


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on (bound by the OS, then closed again)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_http_ok(url: str, process: subprocess.Popen, timeout_s: float, poll_s: float = 0.5) -> float:
    """Seconds until GET `url` answers HTTP 200, asking every `poll_s` s; ServerNotReady (one
    sentence naming the program and the URL) if `process` exits first or `timeout_s` passes."""
    name = Path(str(process.args[0] if isinstance(process.args, (list, tuple)) else process.args)).name
    start = time.monotonic()
    while time.monotonic() - start < timeout_s:
        if process.poll() is not None:
            raise ServerNotReady(f"{name} exited with code {process.returncode} before {url} answered")
        try:
            with urllib.request.urlopen(url, timeout=2) as reply:
                if reply.status == 200:
                    return time.monotonic() - start
        except OSError:  # not listening yet, or an HTTP error status while it starts
            pass
        time.sleep(poll_s)
    raise ServerNotReady(f"{name} did not answer {url} within {timeout_s:g} s")


def start_server(command: list[str], ready_words: str, **popen) -> tuple[subprocess.Popen, list[str]]:
    """Start a server process and return once a line of its output holds `ready_words`, with the
    list its output lines keep going into (read by a thread, so its pipe never fills);
    ServerNotReady if it exits first. Its stderr goes into the same list."""
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **popen)
    lines: list[str] = []
    for line in process.stdout:
        lines.append(line)
        if ready_words in line:
            break
    else:
        process.wait()
        raise ServerNotReady(f"{Path(command[0]).name} exited with code {process.returncode} before saying '{ready_words}'")
    threading.Thread(target=lambda: lines.extend(process.stdout), daemon=True).start()
    return process, lines


def stop_process(process: subprocess.Popen, timeout_s: float = 10.0) -> None:
    """SIGTERM, then SIGKILL if `process` has not exited within `timeout_s`; reaps it."""
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def server_counts(pid: int, port: int) -> dict:
    """What server process `pid` holds now: its child processes (all generations), the ports it and
    they listen on, and the connections established on `port` (for leak checks before and after)."""
    import psutil  # xicm[dev]; also a dependency of wandb

    proc = psutil.Process(pid)
    alive, conns = 0, []
    for member in proc.children(recursive=True):
        try:
            conns += member.net_connections(kind="inet")
        except psutil.NoSuchProcess:  # a child that ended while we counted (a session closing)
            continue
        alive += 1
    conns += proc.net_connections(kind="inet")
    return {
        "children": alive,
        "listening": sorted(c.laddr.port for c in conns if c.status == psutil.CONN_LISTEN),
        "open_on_port": sum(1 for c in conns if c.status == psutil.CONN_ESTABLISHED and c.laddr.port == port),
    }
