"""Do two runs hold the same episodes? Compares two run folders' episodes.jsonl row by row,
keyed by (task, seed, episode), leaving out what may differ between equal runs: `timings`
and, in `extra`, where a row ran (`shard`) and its transcript's path.

    python benchmarks/compare_runs.py RUN_A RUN_B [RUN_C RUN_D ...]   # pairs: A vs B, C vs D
Exit status 0 when every pair matches, 1 otherwise (the first differing rows are printed).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

VOLATILE = ("timings",)
VOLATILE_EXTRA = ("shard", "transcript")


def rows(run: Path) -> dict[tuple, dict]:
    out = {}
    for line in (run / "episodes.jsonl").read_text().splitlines():
        if not line.strip():
            continue
        row = json.loads(line)
        for key in VOLATILE:
            row.pop(key, None)
        row["extra"] = {k: v for k, v in (row.get("extra") or {}).items() if k not in VOLATILE_EXTRA}
        out[(row["task"], row["seed"], row["episode"])] = row
    return out


def compare(a: Path, b: Path) -> list[str]:
    """Sentences naming each difference (none: the runs hold the same episodes)."""
    ra, rb = rows(a), rows(b)
    problems = [f"only in {a}: {k}" for k in ra if k not in rb] + [f"only in {b}: {k}" for k in rb if k not in ra]
    for key in ra.keys() & rb.keys():
        if ra[key] != rb[key]:
            fields = sorted(f for f in ra[key].keys() | rb[key].keys() if ra[key].get(f) != rb[key].get(f))
            problems.append(f"{key}: differs in {', '.join(fields)}")
    return problems


def main(argv: list[str]) -> int:
    if len(argv) < 2 or len(argv) % 2:
        print(__doc__)
        return 2
    failed = 0
    for a, b in zip(argv[::2], argv[1::2]):
        problems = compare(Path(a), Path(b))
        n = len(rows(Path(a)))
        print(f"{a} vs {b}: {n} rows, " + ("identical (timings left out)" if not problems else f"{len(problems)} differences"))
        for p in problems[:10]:
            print("  " + p)
        failed += bool(problems)
    return int(failed > 0)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
