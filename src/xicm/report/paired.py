"""Two runs compared on the episodes both hold (same task, seed, episode: the same scenes), as a
paired test: the exact McNemar test on the episodes where exactly one run succeeded.

`xicm-report --paired RUN_A RUN_B` prints it. Two rows measured on different episode counts
cannot be compared this way; only the common episodes count. `--episodes FIRST:STOP` narrows the
comparison to those episode indices, e.g. the episodes a row gained after its first look, as a
test that the earlier episodes did not choose.
"""

from __future__ import annotations

from math import comb
from typing import Any, Sequence

Key = tuple[str, int, int]


def mcnemar_exact(only_a: int, only_b: int) -> float:
    """Two-sided exact McNemar p-value: the discordant pairs as Binomial(n, 1/2)."""
    n = only_a + only_b
    if n == 0:
        return 1.0
    tail = sum(comb(n, i) for i in range(min(only_a, only_b) + 1)) / 2**n
    return min(1.0, 2 * tail)


def paired_comparison(rows_a: Sequence[dict[str, Any]], rows_b: Sequence[dict[str, Any]],
                      episodes: range | None = None) -> dict[str, Any]:
    """Counts over the common episodes (those in `episodes` only, when given), overall and per task,
    with the McNemar p-value."""
    def outcomes(rows: Sequence[dict[str, Any]]) -> dict[Key, bool]:
        return {(r["task"], int(r["seed"]), int(r["episode"])): bool(r["success"]) for r in rows
                if episodes is None or int(r["episode"]) in episodes}

    a, b = outcomes(rows_a), outcomes(rows_b)
    common = sorted(set(a) & set(b))
    per_task: dict[str, dict[str, int]] = {}
    for key in common:
        cell = per_task.setdefault(key[0], {"n": 0, "a": 0, "b": 0, "only_a": 0, "only_b": 0})
        cell["n"] += 1
        cell["a"] += a[key]
        cell["b"] += b[key]
        cell["only_a"] += a[key] and not b[key]
        cell["only_b"] += b[key] and not a[key]
    total = {field: sum(cell[field] for cell in per_task.values()) for field in ("n", "a", "b", "only_a", "only_b")}
    return {**total, "p_value": mcnemar_exact(total["only_a"], total["only_b"]), "tasks": per_task,
            "only_in_a": len(set(a) - set(b)), "only_in_b": len(set(b) - set(a)), "episodes": episodes}


def episode_range(text: str) -> range:
    """`FIRST:STOP` (STOP excluded, as in a Python slice) as a range; one sentence on anything else."""
    first, sep, stop = text.partition(":")
    if sep and first.strip().isdecimal() and stop.strip().isdecimal() and int(first) < int(stop):
        return range(int(first), int(stop))
    raise ValueError(f"{text!r} is not an episode range FIRST:STOP with 0 <= FIRST < STOP (e.g. 15:25 for episodes 15-24)")


def paired_markdown(result: dict[str, Any], name_a: str, name_b: str) -> str:
    episodes = result.get("episodes")
    within = "" if episodes is None else f", episodes {episodes.start}-{episodes.stop - 1} only"
    lines = [
        f"Paired over {result['n']} common episodes{within} (A = {name_a}, B = {name_b}; "
        f"{result['only_in_a']} episodes only in A, {result['only_in_b']} only in B are left out)\n",
        "| task | n | A | B | only A | only B |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for task, cell in result["tasks"].items():
        lines.append(f"| {task} | {cell['n']} | {cell['a']} | {cell['b']} | {cell['only_a']} | {cell['only_b']} |")
    n = max(1, result["n"])
    lines.append(f"| **all** | {result['n']} | {result['a']} ({100 * result['a'] / n:.1f} %) | "
                 f"{result['b']} ({100 * result['b'] / n:.1f} %) | {result['only_a']} | {result['only_b']} |")
    lines.append(f"\nExact McNemar test on the {result['only_a'] + result['only_b']} discordant episodes: "
                 f"p = {result['p_value']:.3g} (two-sided)")
    return "\n".join(lines)
