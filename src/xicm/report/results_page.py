"""The results page of a folder of committed runs (`xicm-report --results-page results/`): its
README.md and index.html, the best row per setting and every row's figures, paired test and command.

Per setting (a folder of run folders) each row has its successes, Wilson 95 % interval and
Level-1 / Level-2 split, the exact McNemar test against the run settings.yaml pairs it with and
the command that ran it; the best row is marked.

Every figure comes from the run folders through src/xicm/core/results/run_dir.py and the report's own functions
(table2.pooled, paired.paired_comparison); settings.yaml (src/xicm/report/results_settings.py) only names
which run each row is paired against. A folder that cannot be read is left off the page with one
sentence saying why. The output holds no timestamp and is sorted, so it diffs cleanly.
"""

from __future__ import annotations

import json
import shlex
from pathlib import Path
from typing import Any

from xicm.core.results.run_dir import EPISODES, GROWS_ON_RESUME, META, RunDir, find_runs, outside_identity, override_key
from xicm.report.results_settings import SettingDecl, load_settings

PAGE_MD = "README.md"
PAGE_HTML = "index.html"
LEVELS = (("Level-1", "level1"), ("Level-2", "level2"))  # the benchmark's levels, where its tasks have them
REFERENCE_POLICIES = ("oracle",)  # scripted upper bounds: shown and paired, never "the best row"
ROW_KEYS = ("task", "seed", "episode", "success")


def page_command(root: Path) -> str:
    """The command that writes the page, as its header names it (from the repository root)."""
    return f"xicm-report --results-page {Path(root).resolve().name}/"


class RunUnreadable(Exception):
    """A run folder the page leaves off; its message is the one sentence the page prints."""


def build_page(root: Path) -> dict[str, Any]:
    """The page's content: {'command', 'settings': [...], 'skipped': [...], 'paper': ..., 'has_levels'}."""
    from xicm.report import table2

    root = Path(root)
    decls = load_settings(root)
    runs, skipped = _read_runs(root)
    by_setting: dict[str, list[dict[str, Any]]] = {}
    for run in runs:
        by_setting.setdefault(run["setting"], []).append(run)
    settings = [_setting(root, name, by_setting.get(name, []), decls.get(name, SettingDecl()))
                for name in sorted(set(by_setting) | set(decls))]
    return {
        "command": page_command(root),
        "settings": settings,
        "skipped": skipped,
        "paper": table2.paper_table(),
        "has_levels": any(s["has_levels"] for s in settings),
    }


# --- reading the run folders ----------------------------------------------------------------
def _read_runs(root: Path) -> tuple[list[dict[str, Any]], list[dict[str, str]]]:
    """The readable runs below root, and {'path', 'reason'} for each folder left off."""
    runs, skipped = [], []
    found = set(find_runs(root))
    half = {p.parent for name in (EPISODES, META) for p in root.rglob(name)} - found
    for folder in sorted(found | half):
        path = folder.relative_to(root).as_posix()
        try:
            if folder in half:
                missing = META if (folder / EPISODES).is_file() else EPISODES
                raise RunUnreadable(f"it has no {missing}")
            runs.append(_read_run(root, RunDir(folder)))
        except RunUnreadable as exc:
            skipped.append({"path": path, "reason": str(exc)})
    return runs, skipped


def _read_run(root: Path, run: RunDir) -> dict[str, Any]:
    try:
        meta = run.read_meta()
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise RunUnreadable(f"its {META} cannot be read as JSON ({exc})") from None
    if not isinstance(meta, dict) or not isinstance(meta.get("tasks"), list) or not isinstance(meta.get("splits"), dict):
        raise RunUnreadable(f"its {META} lacks the run's tasks and splits")
    try:
        bad = run.corrupt_episode_lines()
        episodes = run.read_episodes()
    except (OSError, UnicodeDecodeError) as exc:
        raise RunUnreadable(f"its {EPISODES} cannot be read as text ({exc})") from None
    if bad:
        more = f" (and {len(bad) - 1} more)" if len(bad) > 1 else ""
        raise RunUnreadable(f"line {bad[0]}{more} of its {EPISODES} is not one JSON row")
    for number, row in enumerate(episodes, 1):
        absent = [k for k in ROW_KEYS if k not in row]
        if absent:
            raise RunUnreadable(f"row {number} of its {EPISODES} has no {absent[0]!r}")
    try:
        rows = run.rows(meta)
    except (KeyError, TypeError, ValueError) as exc:
        raise RunUnreadable(f"its {META} config cannot select its episodes ({type(exc).__name__}: {exc})") from None
    if not rows:
        raise RunUnreadable(f"its {EPISODES} holds none of the episodes its config asks for yet")
    relative = run.path.relative_to(root)
    overrides, note = _overrides(run)
    return {
        "name": run.path.name,
        "setting": relative.parent.as_posix(),
        "path": relative.as_posix(),
        "meta": meta,
        "rows": rows,
        "overrides": overrides,
        "command": _command(root, relative, overrides),
        "command_note": note,
    }


def _overrides(run: RunDir) -> tuple[list[str] | None, str | None]:
    """The job's overrides as Hydra recorded them, or None and why not."""
    if not run.hydra_overrides.is_file():
        return None, "no .hydra/overrides.yaml: the command was not recorded"
    import yaml

    try:
        overrides = yaml.safe_load(run.hydra_overrides.read_text(encoding="utf-8")) or []
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        overrides = None
    if not isinstance(overrides, list):
        return None, ".hydra/overrides.yaml is not a list of overrides: the command is not known"
    return [str(o) for o in overrides], None


def _command(root: Path, relative: Path, overrides: list[str] | None) -> str | None:
    """`xicm-eval <overrides> hydra.run.dir=<the row's folder>`, run from the repository root: it
    resumes the row in place (and refuses, naming the key, if today's config differs from its)."""
    if overrides is None:
        return None
    folder = (Path(Path(root).resolve().name) / relative).as_posix()
    return shlex.join(["xicm-eval", *overrides, f"hydra.run.dir={folder}"])


# --- one setting ------------------------------------------------------------------------------
def _setting(root: Path, name: str, runs: list[dict[str, Any]], decl: SettingDecl) -> dict[str, Any]:
    from xicm.report.paired import paired_comparison

    by_name = {run["name"]: run for run in runs}
    notes = [f"settings.yaml names {n}, which is not a readable run folder of this setting"
             for n in decl.named_runs() if n not in by_name]
    has_levels = any(split in set(run["meta"]["splits"].values()) for run in runs for _, split in LEVELS)
    rows = []
    for run in runs:
        row = _figures(run)
        pairing = decl.pairing(run["name"])
        row["is_baseline"] = run["name"] == decl.baseline
        row["paired"] = None
        if pairing is not None and pairing.baseline in by_name:
            base = by_name[pairing.baseline]
            result = paired_comparison(run["rows"], base["rows"])
            row["paired"] = {**{k: result[k] for k in ("n", "a", "b", "only_a", "only_b", "p_value", "only_in_a", "only_in_b")},
                             "baseline": pairing.baseline, "why": pairing.why,
                             "differs": _differs(run["overrides"], base["overrides"])}
        rows.append(row)
    ranked = sorted((r for r in rows if not r["reference"]), key=_rank)
    if ranked:
        ranked[0]["best"] = True
    rows = ranked + sorted((r for r in rows if r["reference"]), key=_rank)
    return {
        "name": name,
        "link": f"{name}/",
        "facts": _facts(runs),
        "baseline": decl.baseline if decl.baseline in by_name else None,
        "declared_baseline": decl.baseline,
        "rows": rows,
        "best": ranked[0] if ranked else None,
        "has_levels": has_levels,
        "notes": notes,
    }


def _rank(row: dict[str, Any]) -> tuple:
    """Best first: the highest lower end of the Wilson interval (a short row's lucky rate does not
    win), then the higher rate, the more episodes, the name."""
    return (-round(row["ci_low"], 9), -round(row["rate"], 9), -row["n"], row["name"])


def _figures(run: dict[str, Any]) -> dict[str, Any]:
    """A row's successes, rate and Wilson interval, over all its episodes and per level."""
    from xicm.report.table2 import pooled

    meta, rows = run["meta"], run["rows"]
    splits = meta["splits"]
    levels = {}
    for label, split in LEVELS:
        members = [r for r in rows if splits.get(r["task"]) == split]
        if members:
            levels[label] = _with_rate(pooled(members))
    config = meta.get("config") or {}
    policy = str(meta.get("policy") or (config.get("policy") or {}).get("name", "?"))
    return {
        **_with_rate(pooled(rows)),
        "name": run["name"],
        "path": run["path"],
        "link": f"{run['path']}/",
        "method": _method(policy, config, run["overrides"]),
        "levels": levels,
        "reference": policy in REFERENCE_POLICIES,
        "best": False,
        "command": run["command"],
        "command_note": run["command_note"],
    }


def _with_rate(cell: dict[str, Any]) -> dict[str, Any]:
    return {**cell, "rate": 100.0 * cell["successes"] / cell["n"]}


def _method(policy: str, config: dict[str, Any], overrides: list[str] | None) -> str:
    """What acts: the LLM of an X-ICM row (as chosen, `llm=...`), else the policy."""
    return _choice("llm", config, overrides) if policy == "xicm" else f"{policy} policy"


def _choice(group: str, config: dict[str, Any], overrides: list[str] | None) -> str:
    """The config group's option as the command chose it (`retriever=language`), else the name in
    the resolved config (the preset's choice)."""
    chosen = next((o.split("=", 1)[1] for o in overrides or [] if override_key(o) == group and "=" in o), None)
    return str(chosen or (config.get(group) or {}).get("name") or "?")


def _differs(row: list[str] | None, base: list[str] | None) -> list[str] | None:
    """The row's overrides its baseline lacks, then `~override` for the baseline's the row does not
    set, leaving out those that do not change what a run measures (tracking, envs...) and the
    episode counts (the paired test takes the common episodes)."""
    if row is None or base is None:
        return None

    def counts(o: str) -> bool:
        return not outside_identity(o, GROWS_ON_RESUME)

    row_keys = {override_key(o) for o in row}
    extra = [o for o in row if o not in base and counts(o)]
    without = [f"~{o}" for o in base if override_key(o) not in row_keys and counts(o)]
    return extra + without


def _facts(runs: list[dict[str, Any]]) -> list[str]:
    """What the setting's rows were run with, from their configs: benchmark, tasks by split,
    experiment, K and retrievers (several values where the rows differ)."""
    if not runs:
        return ["no readable run folder"]

    def values(get) -> str:
        found = sorted({str(v) for v in map(get, runs) if v is not None})
        return ", ".join(found)

    def config(run):
        return run["meta"].get("config") or {}

    def xicm_only(get):  # keys of the X-ICM policy (the oracle has no K, no retrieval)
        return lambda run: get(run) if (config(run).get("policy") or {}).get("name") == "xicm" else None

    tasks = {t: run["meta"]["splits"].get(t, "?") for run in runs for t in run["meta"]["tasks"]}
    by_split: dict[str, int] = {}
    for split in tasks.values():
        by_split[split] = by_split.get(split, 0) + 1
    split_text = ", ".join(f"{n} {split}" for split, n in sorted(by_split.items()))
    experiment = values(lambda run: next((o.split("=", 1)[1] for o in run["overrides"] or [] if override_key(o) == "experiment"), None))
    facts = [f"benchmark {values(lambda run: (config(run).get('benchmark') or {}).get('name'))}",
             f"{len(tasks)} tasks ({split_text})"]
    if experiment:
        facts.append(f"experiment {experiment}")
    k = values(xicm_only(lambda run: (config(run).get("policy") or {}).get("k")))
    if k:
        facts.append(f"K = {k}")
    retrievers = values(xicm_only(lambda run: _choice("retriever", config(run), run["overrides"])))
    if retrievers:
        facts.append(f"retriever {retrievers}")
    return facts


# --- writing ------------------------------------------------------------------------------------
def write_results_page(root: Path) -> tuple[dict[str, Any], list[Path]]:
    """Write <root>/README.md, then <root>/index.html (that one needs the report extra); the page
    and the paths written."""
    from xicm.core.results.atomic import write_atomic
    from xicm.report.results_markdown import page_markdown

    page = build_page(Path(root))
    md = Path(root) / PAGE_MD
    write_atomic(md, page_markdown(page))
    from xicm.report.html_results import page_html

    html = Path(root) / PAGE_HTML
    write_atomic(html, page_html(page))
    return page, [md, html]
