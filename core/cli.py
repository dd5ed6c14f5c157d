"""Console scripts. Hydra apps share conf/; heavy imports happen only inside the jobs."""

from __future__ import annotations

import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig

import xicm.conf  # noqa: F401  (registers the configs' OmegaConf resolvers and schema)
from xicm.core.errors import XicmError
from xicm.core.plugins import UnknownPluginError

CONFIG_PATH = "../conf"  # core/ and conf/ are siblings in the checkout and in the wheel


def _fail(exc: Exception) -> None:
    print(f"xicm: error: {exc}", file=sys.stderr)
    sys.exit(2)


def _check_command_line() -> None:
    """A command-line value of the wrong type or range, or an unknown key: one sentence, before Hydra composes."""
    from xicm.core.config_schema import XicmConfig
    from xicm.core.schema import check_overrides

    try:
        check_overrides(sys.argv[1:], XicmConfig, xicm.conf.groups())
    except XicmError as exc:
        _fail(exc)


def eval_main() -> None:
    """xicm-eval: evaluate a policy on the benchmark's tasks and print the success table."""
    _check_command_line()
    _eval_job()


def collect_main() -> None:
    """xicm-collect: record scripted demonstrations of benchmark.pool_tasks into pool_path (resumable)."""
    _check_command_line()
    _collect_job()


@hydra.main(version_base="1.3", config_path=CONFIG_PATH, config_name="config")
def _eval_job(cfg: DictConfig) -> None:
    from hydra.core.hydra_config import HydraConfig

    from xicm.core.eval_job import run_eval
    from xicm.core.report import markdown_table

    out_dir = Path(HydraConfig.get().runtime.output_dir)
    try:
        summary = run_eval(cfg, out_dir)
    except (XicmError, UnknownPluginError) as exc:
        _fail(exc)
    print()
    print(markdown_table(summary))
    print(f"\nresults: {out_dir}/ (episodes.jsonl, summary.json, table.md, tasks.csv)")


@hydra.main(version_base="1.3", config_path=CONFIG_PATH, config_name="config")
def _collect_job(cfg: DictConfig) -> None:
    from xicm.core.collect_job import run_collect

    try:
        run_collect(cfg)
    except (XicmError, UnknownPluginError) as exc:
        _fail(exc)


def plugins_main() -> None:
    """Print every loaded plugin with its version and hooks, and what each family offers."""
    from xicm.core.plugins import KINDS, describe_plugins, get_registry

    registry = get_registry()
    for row in describe_plugins(registry.pm):
        print(f"{row['name']} {row['version']}: {', '.join(row['hooks'])}")
    for name, why in sorted(registry.failed.items()):
        print(f"{name}: NOT LOADED ({why})")
    print()
    for kind in KINDS:
        print(f"{kind}: {', '.join(registry.names(kind)) or '-'}")


def report_main(argv: list[str] | None = None) -> None:
    """xicm-report RUN_DIR [RUN_DIR ...]: print the table of finished or partial runs."""
    import json

    from xicm.core.evaluate import EPISODES_FILE, run_rows
    from xicm.core.report import markdown_table, media_lines, summarise

    args = sys.argv[1:] if argv is None else argv
    if not args or args[0] in ("-h", "--help"):
        print(
            "usage: xicm-report DIR [DIR ...]  (xicm-eval output folders, or folders above several of them:\n"
            "a folder with several runs, e.g. a multirun, also gets sweep.md/.csv/.json/.png over the swept keys)\n"
            "       xicm-report --merge OUT_DIR RUN_DIR [RUN_DIR ...]  (one report over runs of one config that\n"
            "cover different tasks or seeds)"
        )
        sys.exit(0 if args else 2)
    if args[0] == "--merge":
        if len(args) < 3:
            _fail(XicmError("usage: xicm-report --merge OUT_DIR RUN_DIR [RUN_DIR ...]"))
        from xicm.core.merge import merge_runs

        try:
            summary = merge_runs(Path(args[1]), [Path(a) for a in args[2:]])
        except XicmError as exc:
            _fail(exc)
        print(markdown_table(summary))
        print(f"\nmerged into {args[1]} (episodes.jsonl, run.json, summary.json, table.md, tasks.csv)")
        return
    for arg in args:
        run_dirs = sorted(p.parent for p in Path(arg).rglob(EPISODES_FILE)) or [Path(arg)]
        for run_dir in run_dirs:
            meta_path = run_dir / "run.json"
            if not (run_dir / EPISODES_FILE).exists() or not meta_path.exists():
                _fail(XicmError(f"{run_dir} has no {EPISODES_FILE} and run.json; pass an xicm-eval output folder"))
            meta = json.loads(meta_path.read_text())
            print(f"## {run_dir}\n")
            rows = run_rows(run_dir, meta)
            print(markdown_table(summarise(rows, meta["splits"], meta["tasks"])))
            for line in media_lines(rows, run_dir):  # rollout videos and LLM transcripts, if any
                print(line)
            print()
        if len(run_dirs) > 1:  # a sweep: one table over the runs, and a plot
            from xicm.core.sweep import sweep_markdown, write_sweep

            sweep = write_sweep(Path(arg), run_dirs)
            print(f"## sweep over {', '.join(sweep['axes']) or 'nothing (the runs share one config)'}\n")
            print(sweep_markdown(sweep))
            print(f"written: {Path(arg) / 'sweep.md'}, sweep.csv, sweep.json, sweep.png\n")
