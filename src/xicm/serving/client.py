"""A client for openpi-style policy servers with time limits and one-sentence errors."""

from __future__ import annotations

from typing import Any

from websockets.exceptions import ConnectionClosed, InvalidHandshake, InvalidStatus, InvalidURI
from websockets.frames import CloseCode
from websockets.protocol import State
from websockets.sync.client import ClientConnection, connect

from xicm.serving.keys import HEADER, header_value
from xicm.serving.wire import MAX_FRAME_BYTES, WireError, pack, unpack


class ServerError(Exception):
    """The server could not be reached, answered late, answered with an error, or sent a frame
    that cannot be decoded."""

    def __init__(self, kind: str, message: str, status: int | None = None):
        super().__init__(message)
        # "server_unreachable" | "server_refused" | "server_timeout" | "server_error" | "bad_reply"
        self.kind = kind
        self.status = status  # the HTTP status of a refused handshake (401: no key, 403: wrong key)


def _peer_text(text: bytes | str | None) -> str:
    """A peer's explanation, safe to print: decoded leniently, one line, at most 200 characters."""
    if isinstance(text, (bytes, bytearray)):
        text = bytes(text[:400]).decode("utf-8", "replace")
    return " ".join("".join(c if c.isprintable() else " " for c in (text or "")).split())[:200]


def server_uri(host: str, port: int | None = None) -> str:
    uri = host if host.startswith(("ws://", "wss://")) else f"ws://{host}"
    return uri if port is None else f"{uri}:{port}"


class PolicyClient:
    """One connection to a policy server: `metadata` (sent by the server at connect) and `infer`."""

    def __init__(self, uri: str, timeout_s: float = 30.0, api_key: str | None = None,
                 max_frame_bytes: int = MAX_FRAME_BYTES):
        self.uri = uri
        self.timeout_s = float(timeout_s)
        self.api_key = api_key
        self.max_frame_bytes = int(max_frame_bytes)  # a bigger reply closes the connection (bad_reply)
        self.metadata: dict = {}
        self._ws: ClientConnection | None = None

    def connect(self) -> dict:
        """(Re)connect; returns the server's metadata. Raises ServerError: "server_unreachable", or
        "server_refused" (HTTP 401/403 at the handshake: no key or a wrong one; or all sessions in use)."""
        self.close()
        headers = {HEADER: header_value(self.api_key)} if self.api_key else None
        try:
            # no keepalive pings: each request has its own timeout_s, and while the main thread holds
            # the GIL in the simulator (a first reset on a busy machine) a pong may be read too late,
            # which would drop a healthy connection
            self._ws = connect(
                self.uri, compression=None, max_size=self.max_frame_bytes, open_timeout=self.timeout_s,
                additional_headers=headers, ping_interval=None,
            )
            frame = self._ws.recv(timeout=self.timeout_s)
        except InvalidStatus as exc:  # refused at the handshake (no key, a wrong key)
            self._ws = None
            status = exc.response.status_code
            why = _peer_text(exc.response.body) or "no reason given"
            raise ServerError("server_refused", f"the policy server at {self.uri} refused the connection with HTTP {status} ({why})", status) from exc
        except ConnectionClosed as exc:
            self._ws = None
            if exc.rcvd is not None and exc.rcvd.code == CloseCode.TRY_AGAIN_LATER:  # all its sessions in use
                why = _peer_text(exc.rcvd.reason) or "no reason given"
                raise ServerError("server_refused", f"the policy server at {self.uri} refused the connection ({why})") from exc
            raise ServerError("server_unreachable", f"no policy server answered at {self.uri} ({type(exc).__name__}: {exc})") from exc
        except (OSError, TimeoutError, InvalidHandshake, InvalidURI) as exc:
            self._ws = None
            raise ServerError("server_unreachable", f"no policy server answered at {self.uri} ({type(exc).__name__}: {exc})") from exc
        try:
            self.metadata = unpack(frame, max_frame_bytes=self.max_frame_bytes)
        except WireError as exc:
            self.metadata = {}
            raise ServerError("server_error", f"the server at {self.uri} sent metadata that cannot be decoded ({exc})") from exc
        if not isinstance(self.metadata, dict):
            raise ServerError("server_error", f"the server at {self.uri} sent metadata that is not a map")
        return self.metadata

    def infer(self, obs: dict) -> Any:
        """Send one observation and return the server's reply (connecting first when not connected,
        or when the server closed the idle connection: the request was not sent, so it is safe)."""
        if self._ws is None or self._ws.state is not State.OPEN:
            self.connect()
        try:
            self._ws.send(pack(obs))
            reply = self._ws.recv(timeout=self.timeout_s)
        except TimeoutError as exc:
            self.close()  # a late reply would answer the next request: start over
            raise ServerError("server_timeout", f"the policy server at {self.uri} did not answer within {self.timeout_s:g} s") from exc
        except (ConnectionClosed, OSError) as exc:
            self.close()
            if isinstance(exc, ConnectionClosed) and exc.sent is not None and exc.sent.code == CloseCode.MESSAGE_TOO_BIG:
                raise ServerError("bad_reply", f"the policy server at {self.uri} sent a reply over the cap of {self.max_frame_bytes} bytes") from exc
            raise ServerError("server_unreachable", f"the connection to {self.uri} was lost ({type(exc).__name__})") from exc
        if isinstance(reply, str):
            raise ServerError("server_error", f"the policy server at {self.uri} failed: {reply.strip()[:300]}")
        try:
            return unpack(reply, max_frame_bytes=self.max_frame_bytes)
        except WireError as exc:  # the connection stays in step: this reply answered this request
            raise ServerError("bad_reply", f"the policy server at {self.uri} sent a reply that cannot be decoded ({exc})") from exc

    def close(self) -> None:
        if self._ws is not None:
            try:
                self._ws.close()
            except Exception:  # noqa: BLE001 - closing a dead link
                pass
            self._ws = None
