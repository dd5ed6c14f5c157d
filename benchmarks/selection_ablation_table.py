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

from xicm.core.results.run_dir import RunDir
from xicm.report.paired import mcnemar_exact
from xicm.report.summary import wilson_interval
from xicm.report.table2 import paper_table

SELECTIONS = ("dynamics", "random", "dynamics_xicm", "language")  # the README's row order
BASELINE = "random"
Key = tuple[str, int, int]


def outcomes(run: Path) -> dict[Key, bool]:
    if not RunDir(run).is_run():
        raise SystemExit(f"{run} is not a run folder (no run.json); run the ablation first (its README)")
    return {(r["task"], int(r["seed"]), int(r["episode"])): bool(r["success"]) for r in RunDir(run).rows()}


def discordant(a: dict[Key, bool], b: dict[Key, bool], keys: set[Key]) -> tuple[int, int]:
    return sum(a[k] and not b[k] for k in keys), sum(b[k] and not a[k] for k in keys)


def percent(k: int, n: int) -> str:
    return f"{k} ({100 * k / n:.1f} %)" if n else "0 (-)"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", nargs="?", type=Path, default=Path("results/agnostos/ablation-selection"))
    parser.add_argument("--llm", default="qwen2_5_coder_0_5b", help="the LLM of the column (its cells' name suffix)")
    args = parser.parse_args()

    llm = {s: outcomes(args.root / f"{s}-{args.llm}") for s in SELECTIONS}
    replay = {s: outcomes(args.root / f"{s}-nearest_demo") for s in SELECTIONS}
    keys = set.intersection(*(set(o) for o in llm.values()))
    missing = [s for s in SELECTIONS if not keys <= set(replay[s])]
    if missing:
        raise SystemExit(f"the replay cells of {', '.join(missing)} lack some of the LLM column's episodes; run their column to as many episodes")
    level1 = set(paper_table()["level1"])
    on1 = {k for k in keys if k[0] in level1}
    n, n1 = len(keys), len(on1)
    print(f"{n} common episodes ({n1} Level-1, {n - n1} Level-2); episode indices {sorted({k[2] for k in keys})}\n")

    print("| selection | successes | Wilson 95 % | Level-1 | Level-2 | against random: only it / only random | exact McNemar p | its replay |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for s in SELECTIONS:
        k = sum(llm[s][key] for key in keys)
        k1 = sum(llm[s][key] for key in on1)
        lo, hi = wilson_interval(k, n)
        if s == BASELINE:
            against = "- | -"
        else:
            a, b = discordant(llm[s], llm[BASELINE], keys)
            against = f"{a} / {b} | {mcnemar_exact(a, b):.3g}"
        print(f"| `{s}` | {percent(k, n)} | {100 * lo:.1f}-{100 * hi:.1f} | {percent(k1, n1)} | {percent(k - k1, n - n1)} | "
              f"{against} | {percent(sum(replay[s][key] for key in keys), n)} |")

    print("\nthe LLM against its own replay (successes LLM / replay; only the LLM / only the replay; p):")
    for s in SELECTIONS:
        a, b = discordant(llm[s], replay[s], keys)
        print(f"  {s}: {sum(llm[s][k] for k in keys)} / {sum(replay[s][k] for k in keys)}; {a} / {b}; p = {mcnemar_exact(a, b):.3g}")

    print("\nthe replay against random's replay (only it / only random; p):")
    for s in SELECTIONS:
        if s != BASELINE:
            a, b = discordant(replay[s], replay[BASELINE], keys)
            print(f"  {s}: {a} / {b}; p = {mcnemar_exact(a, b):.3g}")

    indices = sorted({k[2] for k in keys})
    print(f"\nLLM successes per pair of episode indices ({', '.join(SELECTIONS)}):")
    for i in range(0, len(indices), 2):
        pair = set(indices[i:i + 2])
        label = "-".join(str(j) for j in sorted(pair))
        print(f"  {label}: " + ", ".join(str(sum(llm[s][k] for k in keys if k[2] in pair)) for s in SELECTIONS))


if __name__ == "__main__":
    main()
