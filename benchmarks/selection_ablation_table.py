"""The LLM column of the selection ablation on the episodes its cells share (prints figures; not a test).

Reads the cells `<selection>-<llm>` and `<selection>-nearest_demo` under the ablation folder and,
on the episodes (task, seed, episode) that every LLM cell holds, prints what
results/agnostos/ablation-selection/README.md states about the column:
- per selection: successes, Wilson 95 %, Level-1 and Level-2, the discordant pairs against random
  with the exact McNemar p, and the same selection's LLM-free replay on those episodes;
- per selection: the LLM against its own replay (only the LLM / only the replay, p);
- per selection: the replay against random's replay;
- successes per pair of episode indices, to show how the order moves between them.

    python benchmarks/selection_ablation_table.py                          # the committed cells
    python benchmarks/selection_ablation_table.py DIR --llm qwen2_5_coder_0_5b
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from xicm.core.results.run_dir import RunDir
from xicm.report.paired import paired_comparison
from xicm.report.summary import wilson_interval
from xicm.report.table2 import paper_table

SELECTIONS = ("dynamics", "random", "dynamics_xicm", "language")  # the README's row order
BASELINE = "random"
Key = tuple[str, int, int]


def key(row: dict[str, Any]) -> Key:
    return row["task"], int(row["seed"]), int(row["episode"])


def rows_by_episode(run: Path) -> dict[Key, dict[str, Any]]:
    if not RunDir(run).is_run():
        raise SystemExit(f"{run} is not a run folder (no run.json); run the ablation first (its README)")
    return {key(r): r for r in RunDir(run).rows()}


def percent(k: int, n: int) -> str:
    return f"{k} ({100 * k / n:.1f} %)" if n else "0 (-)"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", nargs="?", type=Path, default=Path("results/agnostos/ablation-selection"))
    parser.add_argument("--llm", default="qwen2_5_coder_0_5b", help="the LLM of the column (its cells' name suffix)")
    args = parser.parse_args()

    llm = {s: rows_by_episode(args.root / f"{s}-{args.llm}") for s in SELECTIONS}
    replay = {s: rows_by_episode(args.root / f"{s}-nearest_demo") for s in SELECTIONS}
    keys = set.intersection(*(set(o) for o in llm.values()))
    missing = [s for s in SELECTIONS if not keys <= set(replay[s])]
    if missing:
        raise SystemExit(f"the replay cells of {', '.join(missing)} lack some of the LLM column's episodes; run their column to as many episodes")

    def paired(a: dict[Key, dict[str, Any]], b: dict[Key, dict[str, Any]]) -> dict[str, Any]:
        """xicm-report --paired's counts, on the episodes every LLM cell holds."""
        return paired_comparison([a[k] for k in keys], [b[k] for k in keys])

    def wins(cell: dict[Key, dict[str, Any]], among: set[Key]) -> int:
        return sum(bool(cell[k]["success"]) for k in among)

    level1 = set(paper_table()["level1"])
    on1 = {k for k in keys if k[0] in level1}
    n, n1 = len(keys), len(on1)
    print(f"{n} common episodes ({n1} Level-1, {n - n1} Level-2); episode indices {sorted({k[2] for k in keys})}\n")

    print("| selection | successes | Wilson 95 % | Level-1 | Level-2 | against random: only it / only random | exact McNemar p | its replay |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for s in SELECTIONS:
        k, k1 = wins(llm[s], keys), wins(llm[s], on1)
        lo, hi = wilson_interval(k, n)
        if s == BASELINE:
            against = "- | -"
        else:
            c = paired(llm[s], llm[BASELINE])
            against = f"{c['only_a']} / {c['only_b']} | {c['p_value']:.3g}"
        print(f"| `{s}` | {percent(k, n)} | {100 * lo:.1f}-{100 * hi:.1f} | {percent(k1, n1)} | {percent(k - k1, n - n1)} | "
              f"{against} | {percent(wins(replay[s], keys), n)} |")

    print("\nthe LLM against its own replay (successes LLM / replay; only the LLM / only the replay; p):")
    for s in SELECTIONS:
        c = paired(llm[s], replay[s])
        print(f"  {s}: {c['a']} / {c['b']}; {c['only_a']} / {c['only_b']}; p = {c['p_value']:.3g}")

    print("\nthe replay against random's replay (only it / only random; p):")
    for s in SELECTIONS:
        if s != BASELINE:
            c = paired(replay[s], replay[BASELINE])
            print(f"  {s}: {c['only_a']} / {c['only_b']}; p = {c['p_value']:.3g}")

    indices = sorted({k[2] for k in keys})
    print(f"\nLLM successes per pair of episode indices ({', '.join(SELECTIONS)}):")
    for i in range(0, len(indices), 2):
        pair = indices[i:i + 2]
        among = {k for k in keys if k[2] in pair}
        print(f"  {'-'.join(map(str, pair))}: " + ", ".join(str(wins(llm[s], among)) for s in SELECTIONS))


if __name__ == "__main__":
    main()
