"""Retriever "object_overlap": demos whose scenes name the same kinds of objects come first.

Score = Jaccard overlap between the words of the query's object names and those of a
demo's object names (e.g. "microwave door handle" and "top drawer handle" share "handle"),
plus 0.1 x the Jaccard overlap of the instructions' words to break ties; remaining ties are
broken with the run's generator. Needs no encoder.

Options:
    instruction_weight: weight of the instruction overlap (default 0.1).
"""

from __future__ import annotations

import re

import numpy as np

from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.interfaces import Retriever

__version__ = "0.1.0"


def words(texts) -> set[str]:
    return {w for text in texts for w in re.findall(r"[a-z]+", text.lower())}


def jaccard(a: set[str], b: set[str]) -> float:
    return len(a & b) / len(a | b) if a or b else 0.0


class ObjectOverlapRetriever(Retriever):
    def __init__(self, encoder=None, instruction_weight: float = 0.1):
        self.instruction_weight = float(instruction_weight)

    def select(self, query, pool, k, rng: np.random.Generator):
        if not pool:
            raise ValueError("the demonstration pool is empty; collect demonstrations first (xicm-collect)")
        query_objects, query_words = words(query.objects), words([query.instruction])
        scores = np.array(
            [
                jaccard(query_objects, words(d.objects)) + self.instruction_weight * jaccard(query_words, words([d.instruction]))
                for d in pool
            ]
        )
        tie_break = rng.random(len(pool))
        order = np.lexsort((tie_break, -scores))[: max(0, min(int(k), len(pool)))]
        return [(pool[i], float(scores[i])) for i in order]


@hookimpl
def register_retrievers(register):
    register("object_overlap", ObjectOverlapRetriever)
