"""Two runs compared on the episodes both hold (same task, seed, episode: the same scenes), as a
paired test: the exact McNemar test on the episodes where exactly one run succeeded.

`xicm-report --paired RUN_A RUN_B` prints it. Two rows measured on different episode counts
cannot be compared this way; only the common episodes count.
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


def paired_comparison(rows_a: Sequence[dict[str, Any]], rows_b: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Counts over the common episodes, overall and per task, with the McNemar p-value."""
    a = {(r["task"], int(r["seed"]), int(r["episode"])): bool(r["success"]) for r in rows_a}
    b = {(r["task"], int(r["seed"]), int(r["episode"])): bool(r["success"]) for r in rows_b}
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
            "only_in_a": len(set(a) - set(b)), "only_in_b": len(set(b) - set(a))}


def paired_markdown(result: dict[str, Any], name_a: str, name_b: str) -> str:
    lines = [
        f"Paired over {result['n']} common episodes (A = {name_a}, B = {name_b}; "
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
