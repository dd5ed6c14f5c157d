"""Run ahead, hand back in key order: the window between a run's loop and the workers that run
its keys ahead (envs=N slots, Ray actors).

The run loop (src/xicm/core/execution/run_loop.py) asks for (task, seed, episode) keys one by one in key order and
alone writes episodes.jsonl; the slots of src/xicm/core/execution/batched_envs.py and the actors of
src/xicm/core/execution/ray_shards.py run keys ahead of it.

At most `size` keys are handed out and not yet handed back, so a killed run loses at most
that many results. The window is bookkeeping only: it is not thread-safe, a caller with
threads holds its own lock around every call.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable
from typing import Any

Key = tuple[str, int, int]


class KeyedWindow:
    def __init__(self, order: Iterable[Key], size: int):
        if size < 1:
            raise ValueError(f"a keyed window holds at least one key, not {size}")
        self.queue: deque[Key] = deque(order)
        self.position = {key: i for i, key in enumerate(self.queue)}  # keys put back return in this order
        self.size = size
        self.running: set[Key] = set()
        self.ready: dict[Key, Any] = {}

    def has_room(self) -> bool:
        """Whether a key is left to hand out and the window has room for it."""
        return bool(self.queue) and len(self.running) + len(self.ready) < self.size

    def take(self, key: Key | None = None) -> Key | None:
        """The next key to run (None when the window is full or no key is left); or `key`
        itself, at once and past the window's size: one asked for out of order."""
        if key is None:
            if not self.has_room():
                return None
            key = self.queue.popleft()
        elif key in self.queue:
            self.queue.remove(key)
        self.running.add(key)
        return key

    def is_running(self, key: Key) -> bool:
        return key in self.running

    def is_ready(self, key: Key) -> bool:
        return key in self.ready

    def done(self, key: Key, result: Any) -> None:
        """A running key's result, kept until the loop asks for it."""
        self.running.discard(key)
        self.ready[key] = result

    def put_back(self, keys: Iterable[Key]) -> None:
        """Running keys whose worker was lost: handed out again first, in key order."""
        lost = [k for k in keys if k in self.running]
        self.running.difference_update(lost)
        self.queue = deque(sorted([*self.queue, *lost], key=lambda k: self.position.get(k, -1)))

    def pop(self, key: Key) -> Any:
        """Hand a ready key's result back (KeyError when it is not ready)."""
        return self.ready.pop(key)

    def stop(self) -> None:
        """Hand out no more keys (the running ones may still finish)."""
        self.queue.clear()
