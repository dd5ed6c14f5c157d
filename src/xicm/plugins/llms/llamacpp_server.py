"""A `llama-server` (llama.cpp) owned by one Python process: built once per machine, started on
a free loopback port, health-checked, stopped with the process.

The binary: ``binary`` when given, else the cached build of scripts/build_llamacpp.sh
(``<cache>/llamacpp/<version>/build/bin/llama-server``), built on first use under a file lock
(about 10 min on 2 cores; a missing compiler or a failed build is one sentence naming the fix).

Lifetime: the server is the child of the process that started it, asked to die with it
(Linux ``PR_SET_PDEATHSIG``, from a spawner thread that lives as long as the process: a
SIGKILLed ``xicm-eval`` leaves no server and no bound port), and stopped by `stop()`, at
interpreter exit, or when the object is collected. `shared_server` gives the LLMs of one
process one server per model and settings.
"""

from __future__ import annotations

import atexit
import ctypes
import os
import shutil
import signal
import subprocess
import sys
import queue
import tempfile
import threading
import time
import weakref
from pathlib import Path

from xicm.core.results.atomic import file_lock
from xicm.core.contracts.errors import ConfigError
from xicm.serving.ports import ServerNotReady, free_port, stop_process, wait_http_ok

LLAMACPP_VERSION = "11434"  # build_llamacpp.sh's default VERSION says the same (a test checks)
# Every reply cached before identity() named the pinned build was decoded by 11434, so that build
# stays unnamed (those caches stay valid) and any other pinned version is named: its replies are
# cached apart.
UNNAMED_BUILD = "11434"
BUILD_SCRIPT = Path(__file__).with_name("build_llamacpp.sh")  # package data: wheel installs build too
STARTS = 3  # a port taken between choosing and binding it is retried with another


def cached_binary() -> Path:
    from xicm.plugins.llms.model_files import cache_root

    return cache_root() / "llamacpp" / LLAMACPP_VERSION / "build" / "bin" / "llama-server"


def llama_server_binary(binary: str | None = None, build: bool = True) -> Path:
    """The llama-server to run: `binary`, else the cached build (built now when missing and `build`)."""
    if binary:
        path = Path(binary).expanduser()
        if not (path.is_file() and os.access(path, os.X_OK)):
            raise ConfigError(f"llm.binary {path} is not an executable file")
        return path
    path = cached_binary()
    if path.is_file():
        return path
    if not build:
        raise ConfigError(f"llama-server is not built yet ({path}); run: bash scripts/build_llamacpp.sh")
    path.parent.parent.parent.mkdir(parents=True, exist_ok=True)
    with file_lock(path.parent.parent.parent / ".build.lock"):
        if not path.is_file():
            _build(path)
    return path


def _build(path: Path) -> None:
    missing = [tool for tool in ("cmake", "g++", "make") if shutil.which(tool) is None]
    if missing:
        raise ConfigError(
            f"building llama-server needs {', '.join(missing)}, not found; install them "
            "(Debian: apt-get install -y cmake build-essential) or set llm.binary to a llama-server"
        )
    print("[xicm] building llama.cpp's llama-server once for this machine (about 10 min on 2 cores)", file=sys.stderr)
    log = path.parents[2] / "build.log"
    with open(log, "w") as out:
        done = subprocess.run(["bash", str(BUILD_SCRIPT)], stdout=out, stderr=subprocess.STDOUT,
                              env={**os.environ, "PYTHON": sys.executable, "VERSION": LLAMACPP_VERSION,
                                   "LOCK": "0"})  # we hold its lock
    if done.returncode != 0 or not path.is_file():
        raise ConfigError(f"building llama-server failed (exit {done.returncode}); see {log}, or run bash {BUILD_SCRIPT}")


def _spawn(argv: list[str], log) -> subprocess.Popen:
    """Popen from one long-lived thread: PR_SET_PDEATHSIG fires when the *thread* that forked
    the child ends, so a server started from a short-lived thread (an `envs=N` slot) would die
    with that thread instead of with the process."""
    global _spawner
    with _spawn_lock:
        if _spawner is None:
            _spawner = _Spawner()
        return _spawner.spawn(argv, log)


class _Spawner:
    def __init__(self):
        self._jobs: queue.Queue = queue.Queue()
        threading.Thread(target=self._run, name="xicm-llama-server-spawner", daemon=True).start()

    def _run(self) -> None:
        while True:
            argv, log, done = self._jobs.get()
            try:
                done.append(subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT,
                                             preexec_fn=_die_with_parent))
            except BaseException as exc:  # noqa: BLE001 - handed back to the caller
                done.append(exc)

    def spawn(self, argv: list[str], log) -> subprocess.Popen:
        done: list = []
        self._jobs.put((argv, log, done))
        while not done:
            time.sleep(0.01)
        if isinstance(done[0], BaseException):
            raise done[0]
        return done[0]


_spawner: _Spawner | None = None
_spawn_lock = threading.Lock()
_shared: dict[tuple, "LlamaServer"] = {}
_shared_lock = threading.Lock()


def shared_server(binary: Path, model: Path, threads: int, ctx_size: int, extra_args: list[str],
                  startup_timeout_s: float, parallel: int = 1) -> "LlamaServer":
    """This process's running server of that model and settings, started when there is none: the
    policies of an `envs=N` run (one process, one policy per slot) share one engine."""
    key = (str(binary), str(model), int(threads), int(ctx_size), tuple(extra_args), int(parallel))
    with _shared_lock:
        server = _shared.get(key)
        if server is None or not server.running():
            server = _shared[key] = LlamaServer(binary, model, threads, ctx_size, extra_args, startup_timeout_s,
                                                parallel).start()
        return server


def _die_with_parent() -> None:  # runs in the child between fork and exec
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG
    if os.getppid() == 1:  # the parent died before prctl took effect
        os._exit(1)


class LlamaServer:
    """One llama-server on 127.0.0.1 serving one GGUF with `parallel` slots. Each slot keeps its
    last prompt in the KV cache, so a request reuses the longest common prefix of the slot it is
    given (llama-server picks the idle slot whose cached prompt is most alike); with several
    slots the KV buffer is one pool of `parallel` x `ctx_size` tokens (--kv-unified), each
    request still limited to ctx_size, and requests in flight together are decoded in one batch."""

    def __init__(self, binary: Path, model: Path, threads: int, ctx_size: int, extra_args: list[str] | None = None,
                 startup_timeout_s: float = 120.0, parallel: int = 1):
        self.binary, self.model = Path(binary), Path(model)
        self.threads, self.ctx_size, self.parallel = int(threads), int(ctx_size), int(parallel)
        self.extra_args = [str(a) for a in (extra_args or [])]
        self.startup_timeout_s = float(startup_timeout_s)
        self.process: subprocess.Popen | None = None
        self.port: int | None = None
        self._log = None
        self._finalizer = None

    @property
    def base_url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def argv(self, port: int) -> list[str]:
        return [
            str(self.binary), "--model", str(self.model), "--host", "127.0.0.1", "--port", str(port),
            "--threads", str(self.threads), "--threads-batch", str(self.threads), *self.slot_args(),
            "--jinja", "--no-webui", *self.extra_args,
        ]

    def slot_args(self) -> list[str]:
        if self.parallel == 1:
            return ["--ctx-size", str(self.ctx_size), "--parallel", "1"]
        return ["--ctx-size", str(self.ctx_size * self.parallel), "--parallel", str(self.parallel),
                "--kv-unified", "--kv-unified-per-slot", str(self.ctx_size)]

    def start(self) -> LlamaServer:
        if self.running():
            return self
        reason = "no output"
        for _ in range(STARTS):
            self._log = tempfile.NamedTemporaryFile(prefix="xicm-llama-server-", suffix=".log", delete=False)
            port = free_port()
            process = _spawn(self.argv(port), self._log)
            self.process, self.port = process, port
            self._finalizer = weakref.finalize(self, _stop_process, process, self._log.name)
            atexit.register(self._finalizer)
            if self._wait_healthy():
                return self
            reason = self.log_tail() or f"not healthy within {self.startup_timeout_s:g} s"
            self.stop()
            if "bind" not in reason.lower():  # only a port taken meanwhile is worth another try
                break
        raise ConfigError(f"llama-server did not start on {self.model.name}: {reason}")

    def _wait_healthy(self) -> bool:
        try:  # /health answers 503 while the model loads
            wait_http_ok(f"{self.base_url}/health", self.process, self.startup_timeout_s, poll_s=0.1)
        except ServerNotReady:
            return False
        return True

    def running(self) -> bool:
        return self.process is not None and self.process.poll() is None

    def log_tail(self, lines: int = 2) -> str:
        try:
            text = Path(self._log.name).read_text(errors="replace").strip().splitlines()
        except (OSError, AttributeError):
            return ""
        useful = [line for line in text if "error" in line.lower()] or text
        return " | ".join(line.strip() for line in useful[-lines:])[:300]

    def stop(self) -> None:
        if self._finalizer is not None:
            self._finalizer()
            atexit.unregister(self._finalizer)
        self.process = None


def _stop_process(process: subprocess.Popen, log: str) -> None:
    stop_process(process, timeout_s=5)
    try:
        os.unlink(log)
    except OSError:
        pass
