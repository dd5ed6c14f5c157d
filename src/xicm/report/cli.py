"""xicm-report: the success table of finished or partial xicm-eval runs, sweeps over several,
merged and paired reports, the results page of a results folder, and the HTML pages (those need
the `report` extra)."""

from __future__ import annotations

import argparse
from pathlib import Path

from xicm.core.contracts.errors import XicmError
from xicm.core.contracts.errors import exit_with_error as _fail
from xicm.report import ReportExtraMissing


def report_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="xicm-report",
        description="Print the success table of finished or partial xicm-eval runs.",
    )
    parser.add_argument(
        "dirs", nargs="+", metavar="DIR",
        help="an xicm-eval output folder, or a folder above several (e.g. a multirun): every run below it gets "
        "its table, and a folder with several runs also gets sweep.md/.csv/.json/.png over the swept keys",
    )
    parser.add_argument(
        "--merge", metavar="OUT_DIR",
        help="instead, write one report over the runs DIR... (one config, covering different tasks or seeds) into OUT_DIR",
    )
    parser.add_argument(
        "--html", action="store_true",
        help="also write each run's self-contained report.html (Table-2 layout beside the paper's rows, tasks, "
        "episodes with demos, transcripts and videos) and, over several runs, sweep.html",
    )
    parser.add_argument(
        "--paired", action="store_true",
        help="instead, compare two runs DIR_A DIR_B on the episodes both hold: per-task counts and the exact McNemar test",
    )
    parser.add_argument(
        "--results-page", action="store_true",
        help="instead, write the results page of one results folder DIR (e.g. results/): DIR/README.md and DIR/index.html, "
        "every row of every setting with its interval, paired test and command, the best row marked (DIR/settings.yaml "
        "names each setting's baseline)",
    )
    parser.add_argument(
        "--episodes", type=_episode_range, default=None, metavar="FIRST:STOP",
        help="with --paired: compare only episodes FIRST to STOP-1 of each task and seed (e.g. 15:25)",
    )
    parser.add_argument(
        "--pool", metavar="PATH",
        help="with --html: the demonstration pool to take retrieved demos' first frames from "
        "(default: the run's pool_path, as recorded or relative to the run folder)",
    )
    parser.add_argument(
        "--inline-video-mb", type=_non_negative, default=None, metavar="MB",
        help="with --html: inline videos up to this size, link larger ones (default: the run's report.inline_video_mb, else 2)",
    )
    return parser


def _non_negative(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of megabytes >= 0")
    return value


def _episode_range(text: str) -> range:
    from xicm.report.paired import episode_range

    try:
        return episode_range(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _write_html(run_dir: Path, args: argparse.Namespace) -> None:
    from xicm.report.html_run import INLINE_VIDEO_MB, write_run_html
    from xicm.core.results.run_dir import RunDir

    limit = args.inline_video_mb
    if limit is None:
        limit = ((RunDir(run_dir).read_meta().get("config") or {}).get("report") or {}).get("inline_video_mb", INLINE_VIDEO_MB)
    path = write_run_html(run_dir, inline_video_mb=float(limit), pool=args.pool)
    print(f"written: {path} ({path.stat().st_size / 1e6:.2f} MB)\n")


def _print_paired(dirs: list[str], episodes: range | None) -> None:
    from xicm.report.paired import paired_comparison, paired_markdown
    from xicm.core.results.run_dir import RunDir

    if len(dirs) != 2:
        _fail(XicmError(f"--paired compares two runs, not {len(dirs)}: xicm-report --paired RUN_A RUN_B"))
    try:
        rows = [RunDir(Path(d)).rows(RunDir(Path(d)).read_meta()) for d in dirs]
    except (XicmError, OSError) as exc:
        _fail(XicmError(str(exc)))
    print(paired_markdown(paired_comparison(*rows, episodes=episodes), dirs[0], dirs[1]))


def _write_results_page(dirs: list[str]) -> None:
    from xicm.report.results_page import write_results_page

    if len(dirs) != 1:
        _fail(XicmError(f"--results-page writes the page of one results folder, not {len(dirs)}: xicm-report --results-page results/"))
    if not Path(dirs[0]).is_dir():
        _fail(XicmError(f"{dirs[0]} is not a folder: xicm-report --results-page takes the folder of committed runs (results/)"))
    try:
        page, paths = write_results_page(Path(dirs[0]))
    except (XicmError, OSError) as exc:
        _fail(XicmError(str(exc)))
    for item in page["skipped"]:
        print(f"left off the page: {item['path']}: {item['reason']}")
    rows = sum(len(s["rows"]) for s in page["settings"])
    print(f"written: {', '.join(map(str, paths))} ({len(page['settings'])} settings, {rows} rows)")


def main(argv: list[str] | None = None) -> None:
    """xicm-report DIR [DIR ...] [--html] | --merge OUT_DIR RUN_DIR [RUN_DIR ...] (see report_parser)."""
    try:
        _report(argv)
    except ReportExtraMissing as exc:  # a page or plot without jinja2/matplotlib; the tables are written
        _fail(exc)


def _report(argv: list[str] | None) -> None:
    from xicm.report.summary import markdown_table, media_lines, std_ddof, summarise
    from xicm.core.results.run_dir import EPISODES, META, REPORT_FILES, RunDir, find_runs

    args = report_parser().parse_args(argv)
    if args.results_page:
        _write_results_page(args.dirs)
        return
    if args.paired:
        _print_paired(args.dirs, args.episodes)
        return
    if args.episodes is not None:
        _fail(XicmError("--episodes narrows a paired comparison: xicm-report --paired RUN_A RUN_B --episodes FIRST:STOP"))
    if args.merge is not None:
        from xicm.report.merge import merge_runs

        try:
            summary = merge_runs(Path(args.merge), [Path(d) for d in args.dirs])
        except XicmError as exc:
            _fail(exc)
        print(markdown_table(summary))
        print(f"\nmerged into {args.merge} ({', '.join((EPISODES, META, *REPORT_FILES))})")
        if args.html:
            _write_html(Path(args.merge), args)
        return
    for arg in args.dirs:
        run_dirs = find_runs(Path(arg))
        if not run_dirs:
            _fail(XicmError(f"{arg} has no {EPISODES} and {META}, nor a folder below it; pass an xicm-eval output folder"))
        for run_dir in run_dirs:
            run = RunDir(run_dir)
            meta = run.read_meta()
            print(f"## {run_dir}\n")
            rows = run.rows(meta)
            print(markdown_table(summarise(rows, meta["splits"], meta["tasks"], std_ddof(meta))))
            for line in media_lines(rows, run_dir):  # rollout videos and LLM transcripts, if any
                print(line)
            print()
            if args.html:
                _write_html(run_dir, args)
        if len(run_dirs) > 1:  # a sweep: one table over the runs, and a plot
            from xicm.report.sweep import SWEEP_FILES, sweep_markdown, write_sweep

            sweep = write_sweep(Path(arg), run_dirs)
            print(f"## sweep over {', '.join(sweep['axes']) or 'nothing (the runs share one config)'}\n")
            print(sweep_markdown(sweep))
            print(f"written: {Path(arg) / SWEEP_FILES[0]}, {', '.join(SWEEP_FILES[1:])}\n")
            if args.html:
                from xicm.report.html_sweep import write_sweep_html

                path = write_sweep_html(Path(arg), run_dirs)
                print(f"written: {path} ({path.stat().st_size / 1e6:.2f} MB)\n")
