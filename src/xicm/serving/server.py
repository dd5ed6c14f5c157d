"""A policy server in openpi's websocket dialect, for any object with `infer(obs) -> dict`.

At connect the server sends its metadata; then every binary frame from the client is one
observation and is answered with one binary frame (the policy's output dict, usually
{"actions": array}). A failing `infer`, or a frame that cannot be decoded safely (src/xicm/serving/wire.py),
is answered with a text frame holding one sentence and the connection stays open (openpi's own
server closes it); a frame over `max_frame_bytes` closes only its connection (close code 1009).
`GET /healthz` answers 200 "OK" (always, without a key).

With `api_key` set, a handshake without the header `Authorization: Api-Key <key>` (openpi-client's)
is answered HTTP 401, one with another key 403, before any session or simulator work. At most
`max_sessions` connections are served at once (another one is closed at once with code 1013 and
a reason); a connection silent for `idle_timeout_s` between requests is closed (code 1000).
A stateless policy with `infer_batch(observations) -> replies` may be served with `max_batch` > 1:
requests from several connections are then answered together (src/xicm/serving/batching.py).
"""

from __future__ import annotations

import asyncio
import http
import logging
import threading
from typing import Any, Protocol

from websockets.asyncio.server import Request, Response, ServerConnection, serve
from websockets.exceptions import ConnectionClosed
from websockets.frames import CloseCode

from xicm.serving.batching import RequestBatcher
from xicm.serving.keys import HEADER, is_loopback, key_matches
from xicm.serving.limits import IDLE_TIMEOUT_S, MAX_SESSIONS
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


def _gate(api_key: str | None):
    """The handshake's first step: /healthz answers, a request without the right key is refused."""
    def process_request(connection: ServerConnection, request: Request) -> Response | None:
        if request.path == "/healthz":
            return connection.respond(http.HTTPStatus.OK, "OK\n")
        if api_key is None:
            return None  # on to the websocket handshake
        sent = request.headers.get_all(HEADER)
        if not sent:
            log.warning("refused %s: no key", connection.remote_address)
            return connection.respond(http.HTTPStatus.UNAUTHORIZED, f"this server needs a key: send the header '{HEADER}: Api-Key <key>'\n")
        if len(sent) > 1 or not key_matches(sent[0], api_key):
            log.warning("refused %s: wrong key", connection.remote_address)
            return connection.respond(http.HTTPStatus.FORBIDDEN, f"the key sent in the {HEADER} header is wrong\n")
        return None
    return process_request


class PolicyServer:
    """Serves `policy` on host:port (port 0: the OS picks one; `port` holds it once started).

    A stateless policy (openpi's kind) is shared by all connections, one `infer` at a time; a
    `Sessions` policy gives each connection its own session (which may share a lock of its own).
    """

    def __init__(self, policy: InferencePolicy | Sessions, host: str = "127.0.0.1", port: int = 8000,
                 metadata: dict | None = None, max_batch: int = 1, batch_wait_ms: float = 5.0,
                 max_frame_bytes: int = MAX_FRAME_BYTES, api_key: str | None = None,
                 max_sessions: int | None = MAX_SESSIONS, idle_timeout_s: float | None = IDLE_TIMEOUT_S,
                 key_setting: str = "a key"):
        if max_sessions is not None and max_sessions < 1:
            raise ValueError(f"max_sessions must be >= 1 or None, got {max_sessions}")
        if idle_timeout_s is not None and idle_timeout_s <= 0:
            raise ValueError(f"idle_timeout_s must be > 0 or None, got {idle_timeout_s}")
        self.policy = policy
        self.api_key = api_key or None
        self.max_sessions = max_sessions
        self.idle_timeout_s = idle_timeout_s
        self.key_setting = key_setting  # how this server's operator sets a key (for the warning)
        self.active = 0  # connections being served now
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
        if self.max_sessions is not None and self.active >= self.max_sessions:
            log.warning("refused %s: %d sessions in use", ws.remote_address, self.active)
            await ws.close(CloseCode.TRY_AGAIN_LATER, f"the server is at its cap of {self.max_sessions} sessions; try again later")
            return
        self.active += 1  # no await since the check: no other handler runs in between
        log.info("connection from %s (%d in use)", ws.remote_address, self.active)
        try:
            await ws.send(pack(self.metadata))  # at once: a new session may take a while to build
            if hasattr(self.policy, "open_session"):
                session = await asyncio.to_thread(self.policy.open_session)
                try:
                    await self._serve_connection(ws, _in_thread(session.infer))
                finally:  # a client gone mid-episode hands its session back too
                    await asyncio.to_thread(self.policy.close_session, session)
            elif self.batcher is not None:
                await self._serve_connection(ws, self.batcher.infer)
            else:
                await self._serve_connection(ws, _in_thread(self._infer_shared))
        except ConnectionClosed:  # the client went away while we answered
            pass
        finally:
            self.active -= 1

    async def _serve_connection(self, ws: ServerConnection, infer) -> None:
        while True:
            try:
                frame = await asyncio.wait_for(ws.recv(), self.idle_timeout_s)
            except ConnectionClosed:
                return
            except asyncio.TimeoutError:  # websockets: cancelling recv() loses no frame
                log.info("closing %s: idle for %g s", ws.remote_address, self.idle_timeout_s)
                await ws.close(CloseCode.NORMAL_CLOSURE, f"idle for more than {self.idle_timeout_s:g} s")
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
                         max_size=self.max_frame_bytes, process_request=_gate(self.api_key)) as server:
            self.port = server.sockets[0].getsockname()[1]
            if started is not None:
                started.set()
            await self._stop.wait()

    def start(self) -> PolicyServer:
        """Serve from a background thread; returns once the port is open."""
        if self.api_key is None and not is_loopback(self.host):
            log.warning("serving on %s without a key: anyone who reaches this port can use the policy and its simulator (set %s)",
                        self.host, self.key_setting)
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
