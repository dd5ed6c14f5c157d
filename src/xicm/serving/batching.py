"""Server-side batching: requests that arrive from several connections within a short window are
answered by one `infer_batch(observations) -> replies` call (one forward pass for N environments,
as harnesses that step environments in lockstep send them).

The window opens when a request finds the batcher idle and closes after `wait_ms` or at
`max_batch` requests, whichever comes first. If the batch call fails, each request of it is
retried alone, so one bad request gets its own error and the others their replies.
"""

from __future__ import annotations

import asyncio
from typing import Any, Callable


class RequestBatcher:
    """Runs inside the server's event loop; `infer(obs)` is awaited by each connection."""

    def __init__(self, infer_batch: Callable[[list[dict]], list[Any]], infer_one: Callable[[dict], Any],
                 max_batch: int, wait_ms: float):
        if max_batch < 1:
            raise ValueError(f"max_batch must be >= 1, got {max_batch}")
        if wait_ms < 0:
            raise ValueError(f"the batching window must be >= 0 ms, got {wait_ms}")
        self.infer_batch = infer_batch
        self.infer_one = infer_one
        self.max_batch = int(max_batch)
        self.wait_s = float(wait_ms) / 1000.0
        self.batch_sizes: list[int] = []  # one entry per batch run, for logs and benchmarks
        self._pending: list[tuple[dict, asyncio.Future]] = []
        self._full: asyncio.Event | None = None
        self._worker: asyncio.Task | None = None

    async def infer(self, obs: dict) -> Any:
        loop = asyncio.get_running_loop()
        future = loop.create_future()
        self._pending.append((obs, future))
        if self._full is None:
            self._full = asyncio.Event()
        if len(self._pending) >= self.max_batch:
            self._full.set()
        if self._worker is None or self._worker.done():
            self._worker = loop.create_task(self._drain())
        return await future

    async def _drain(self) -> None:
        while self._pending:
            try:
                await asyncio.wait_for(self._full.wait(), timeout=self.wait_s)
            except TimeoutError:
                pass
            batch, self._pending = self._pending[: self.max_batch], self._pending[self.max_batch:]
            if len(self._pending) < self.max_batch:
                self._full.clear()
            self.batch_sizes.append(len(batch))
            await self._answer(batch)

    async def _answer(self, batch: list[tuple[dict, asyncio.Future]]) -> None:
        observations = [obs for obs, _ in batch]
        try:
            replies = await asyncio.to_thread(self.infer_batch, observations)
            if len(replies) != len(batch):
                raise ValueError(f"infer_batch answered {len(replies)} replies to {len(batch)} requests")
        except Exception:  # noqa: BLE001 - isolate the failing request: each one alone
            for obs, future in batch:
                try:
                    reply = await asyncio.to_thread(self.infer_one, obs)
                except Exception as exc:  # noqa: BLE001 - this request's own reason
                    if not future.done():  # done: its connection went away meanwhile
                        future.set_exception(exc)
                    continue
                if not future.done():
                    future.set_result(reply)
            return
        for (_, future), reply in zip(batch, replies):
            if not future.done():
                future.set_result(reply)
