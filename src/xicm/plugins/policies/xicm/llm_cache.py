"""On-disk LLM response cache (SQLite), shared safely by several processes.

Key: sha256 of the LLM's identity() and the prompt messages (JSON, sorted keys). Only
worth using when decoding is deterministic (greedy, or sampling seeded per call): then a
resumed or repeated run gets the same replies without running the model again.

The database uses WAL journaling and a busy timeout, so concurrent readers never block and
concurrent writers wait for each other instead of failing; the first reply stored under a
key wins. Each process (and each fork) opens its own connection.
"""

from __future__ import annotations

import hashlib
import json
import os
import sqlite3
import threading
import time
from pathlib import Path
from typing import Any

from xicm.core.contracts.interfaces import LLM
from xicm.core.contracts.types import Prompt

_SCHEMA = """
CREATE TABLE IF NOT EXISTS responses (
    key TEXT PRIMARY KEY,
    identity TEXT NOT NULL,
    response TEXT NOT NULL,
    created REAL NOT NULL
)
"""


def cache_key(identity: str, messages: list[dict[str, Any]]) -> str:
    """sha256 hex of the identity string and the messages as canonical JSON."""
    payload = json.dumps({"identity": identity, "messages": messages}, sort_keys=True, ensure_ascii=False)
    return hashlib.sha256(payload.encode("utf-8")).hexdigest()


class ResponseCache:
    """get/put of reply texts by key in one SQLite file."""

    def __init__(self, path: str | os.PathLike, timeout_s: float = 60.0):
        self.path = Path(path).expanduser()
        self.timeout_s = float(timeout_s)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._local = threading.local()
        self._connect()  # create the file and table now so a bad path fails at start

    def _connect(self) -> sqlite3.Connection:
        conn = getattr(self._local, "conn", None)
        if conn is not None and getattr(self._local, "pid", None) == os.getpid():
            return conn
        conn = sqlite3.connect(str(self.path), timeout=self.timeout_s, isolation_level=None)
        conn.execute(f"PRAGMA busy_timeout = {int(self.timeout_s * 1000)}")
        self._retry(lambda: conn.execute("PRAGMA journal_mode = WAL"))
        conn.execute("PRAGMA synchronous = NORMAL")
        self._retry(lambda: conn.execute(_SCHEMA))
        self._local.conn = conn
        self._local.pid = os.getpid()
        return conn

    def _retry(self, fn):
        """Run fn, retrying 'database is locked' until timeout_s (busy_timeout covers most cases)."""
        deadline = time.monotonic() + self.timeout_s
        delay = 0.01
        while True:
            try:
                return fn()
            except sqlite3.OperationalError as exc:
                if "locked" not in str(exc) and "busy" not in str(exc) or time.monotonic() > deadline:
                    raise
                time.sleep(delay)
                delay = min(delay * 2, 0.5)

    def get(self, key: str) -> str | None:
        conn = self._connect()
        row = self._retry(lambda: conn.execute("SELECT response FROM responses WHERE key = ?", (key,)).fetchone())
        return None if row is None else row[0]

    def put(self, key: str, response: str, identity: str = "") -> None:
        conn = self._connect()
        self._retry(
            lambda: conn.execute(
                "INSERT OR IGNORE INTO responses (key, identity, response, created) VALUES (?, ?, ?, ?)",
                (key, identity, response, time.time()),
            )
        )

    def __len__(self) -> int:
        conn = self._connect()
        return int(self._retry(lambda: conn.execute("SELECT COUNT(*) FROM responses").fetchone())[0])

    def close(self) -> None:
        conn = getattr(self._local, "conn", None)
        if conn is not None and getattr(self._local, "pid", None) == os.getpid():
            conn.close()
        self._local.conn = None


class CachedLLM(LLM):
    """An LLM that answers from the cache when it can and stores every new reply.

    ``enabled=None`` (default) caches only when the wrapped LLM says its decoding is
    deterministic (``LLM.deterministic``); True/False force it.
    Errors of the wrapped LLM propagate and are never cached.
    """

    def __init__(self, llm: LLM, path: str | os.PathLike, enabled: bool | None = None):
        self.llm = llm
        self.cache = ResponseCache(path)
        self.enabled = bool(llm.deterministic) if enabled is None else bool(enabled)
        self.hits = 0
        self.misses = 0

    def key(self, prompt: Prompt) -> str:
        return cache_key(self.llm.identity(), prompt.messages)

    def complete(self, prompt: Prompt) -> str:
        if not self.enabled:
            return self.llm.complete(prompt)
        key = self.key(prompt)
        cached = self.cache.get(key)
        if cached is not None:
            self.hits += 1
            return cached
        self.misses += 1
        response = self.llm.complete(prompt)
        self.cache.put(key, response, self.llm.identity())
        return response

    def identity(self) -> str:
        return self.llm.identity()

    @property
    def concurrent_requests(self) -> int:  # type: ignore[override]
        return int(getattr(self.llm, "concurrent_requests", 1))

    @property
    def deterministic(self) -> bool:
        return bool(self.llm.deterministic)
