"""A policy server in openpi's websocket dialect, for any object with `infer(obs) -> dict`.

At connect the server sends its metadata; then every binary frame from the client is one
observation and is answered with one binary frame (the policy's output dict, usually
{"actions": array}). A failing `infer`, or a frame that cannot be decoded safely (serving/wire.py),
is answered with a text frame holding one sentence and the connection stays open (openpi's own
server closes it); a frame over `max_frame_bytes` closes only its connection (close code 1009).
`GET /healthz` answers 200 "OK".
A stateless policy with `infer_batch(observations) -> replies` may be served with `max_batch` > 1:
requests from several connections are then answered together (serving/batching.py).
"""

from __future__ import annotations

import asyncio
import http
import logging
import threading
from typing import Any, Protocol

from websockets.asyncio.server import Request, Response, ServerConnection, serve
from websockets.exceptions import ConnectionClosed

from xicm.serving.batching import RequestBatcher
from xicm.serving.wire import MAX_FRAME_BYTES, WireError, pack, unpack

log = logging.getLogger(__name__)


class InferencePolicy(Protocol):
    def infer(self, obs: dict) -> dict: ...


class Sessions(Protocol):
    """A policy with state per client (xicm policies run episodes): each connection gets its own
    session from `open_session()`, handed back with `close_session(session)` when it ends."""

    def open_session(self) -> InferencePolicy: ...

    def close_session(self, session: InferencePolicy) -> None: ...


def _in_thread(infer):
    """infer(obs) as a coroutine run in a worker thread (the event loop keeps serving)."""
    async def run(obs: dict) -> Any:
        return await asyncio.to_thread(infer, obs)
    return run


def _health(connection: ServerConnection, request: Request) -> Response | None:
    if request.path == "/healthz":
        return connection.respond(http.HTTPStatus.OK, "OK\n")
    return None  # anything else goes on to the websocket handshake


class PolicyServer:
    """Serves `policy` on host:port (port 0: the OS picks one; `port` holds it once started).

    A stateless policy (openpi's kind) is shared by all connections, one `infer` at a time; a
    `Sessions` policy gives each connection its own session (which may share a lock of its own).
    """

    def __init__(self, policy: InferencePolicy | Sessions, host: str = "127.0.0.1", port: int = 8000,
                 metadata: dict | None = None, max_batch: int = 1, batch_wait_ms: float = 5.0,
                 max_frame_bytes: int = MAX_FRAME_BYTES):
        self.policy = policy
        self.max_frame_bytes = int(max_frame_bytes)
        self.host = host
        self.port = int(port)
        self.metadata = dict(metadata or {})
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop: asyncio.Event | None = None
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()  # one infer at a time: policies are not thread-safe
        self.batcher = None
        if max_batch > 1:
            if hasattr(policy, "open_session") or not hasattr(policy, "infer_batch"):
                raise ValueError(f"max_batch={max_batch} needs a stateless policy with infer_batch; {type(policy).__name__} has none")
            self.batcher = RequestBatcher(self._infer_batch_shared, self._infer_shared, max_batch, batch_wait_ms)

    async def _handle(self, ws: ServerConnection) -> None:
        log.info("connection from %s", ws.remote_address)
        await ws.send(pack(self.metadata))  # at once: a new session may take a while to build
        if hasattr(self.policy, "open_session"):
            session = await asyncio.to_thread(self.policy.open_session)
            try:
                await self._serve_connection(ws, _in_thread(session.infer))
            finally:
                self.policy.close_session(session)
        elif self.batcher is not None:
            await self._serve_connection(ws, self.batcher.infer)
        else:
            await self._serve_connection(ws, _in_thread(self._infer_shared))

    async def _serve_connection(self, ws: ServerConnection, infer) -> None:
        while True:
            try:
                frame = await ws.recv()
            except ConnectionClosed:
                return
            try:
                if isinstance(frame, str):
                    raise TypeError("the observation frame must be binary msgpack, got text")
                obs = unpack(frame, max_frame_bytes=self.max_frame_bytes)
                if not isinstance(obs, dict):
                    raise TypeError(f"the observation must be a map, got {type(obs).__name__}")
            except (TypeError, WireError) as exc:  # a bad frame costs only its answer
                log.warning("bad frame from %s: %s: %s", ws.remote_address, type(exc).__name__, exc)
                await ws.send(f"{type(exc).__name__}: {exc}")
                continue
            try:
                reply = await infer(obs)
            except Exception as exc:  # noqa: BLE001 - the client gets the reason, the server goes on
                log.warning("infer failed: %s: %s", type(exc).__name__, exc)
                await ws.send(f"{type(exc).__name__}: {exc}")
                continue
            await ws.send(pack(reply))

    def _infer_shared(self, obs: dict) -> Any:
        with self._lock:
            return self.policy.infer(obs)

    def _infer_batch_shared(self, observations: list[dict]) -> list[Any]:
        with self._lock:
            return self.policy.infer_batch(observations)

    async def _serve(self, started: threading.Event | None) -> None:
        self._stop = asyncio.Event()
        async with serve(self._handle, self.host, self.port, compression=None,
                         max_size=self.max_frame_bytes, process_request=_health) as server:
            self.port = server.sockets[0].getsockname()[1]
            if started is not None:
                started.set()
            await self._stop.wait()

    def start(self) -> PolicyServer:
        """Serve from a background thread; returns once the port is open."""
        started = threading.Event()

        def run() -> None:
            self._loop = asyncio.new_event_loop()
            self._loop.run_until_complete(self._serve(started))

        self._thread = threading.Thread(target=run, name="policy-server", daemon=True)
        self._thread.start()
        if not started.wait(timeout=30):
            raise RuntimeError(f"the policy server did not start on {self.host}:{self.port} within 30 s")
        return self

    def wait(self) -> None:
        """Block until the background server stops (Ctrl-C raises KeyboardInterrupt here)."""
        while self._thread is not None and self._thread.is_alive():
            self._thread.join(timeout=0.5)

    def stop(self) -> None:
        if self._loop is not None and self._stop is not None:
            self._loop.call_soon_threadsafe(self._stop.set)
        if self._thread is not None:
            self._thread.join(timeout=10)
