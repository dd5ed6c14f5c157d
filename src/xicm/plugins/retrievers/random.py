"""Retriever "random": k distinct demos drawn uniformly with the run's generator (score 0).

The X-ICM ablation without dynamics-guided selection. The same seeded generator and pool
give the same draw in any process.

Options:
    exclude_same_task: leave out demos of the query's own task (leave-one-task-out
        studies), default False.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.interfaces import Retriever
from xicm.core.contracts.types import Demo, Query


def candidates(query: Query, pool: list[Demo], exclude_same_task: bool) -> list[Demo]:
    """The demos a retriever may choose from; ValueError when there are none."""
    if not pool:
        raise ValueError("the demonstration pool is empty; collect demonstrations first (xicm-collect)")
    if not exclude_same_task:
        return list(pool)
    chosen = [d for d in pool if d.task != query.task]
    if not chosen:
        raise ValueError(f"the demonstration pool has no demos of tasks other than '{query.task}'")
    return chosen


@dataclass
class RandomOptions:
    exclude_same_task: bool = False


class RandomRetriever(Retriever):
    def __init__(self, options: RandomOptions | None = None, encoder=None):
        self.exclude_same_task = (options or RandomOptions()).exclude_same_task  # the encoder is not needed

    def select(self, query: Query, pool: list[Demo], k: int, rng: np.random.Generator) -> list[tuple[Demo, float]]:
        demos = candidates(query, pool, self.exclude_same_task)
        k = max(0, min(int(k), len(demos)))
        idx = rng.choice(len(demos), size=k, replace=False)
        return [(demos[int(i)], 0.0) for i in idx]


@hookimpl
def register_retrievers(register):
    register("random", RandomRetriever, options=RandomOptions)
