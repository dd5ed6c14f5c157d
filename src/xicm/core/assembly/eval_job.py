"""xicm-eval's job: build the plugins from the config, run the episodes, write the report."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf

from xicm.core.assembly import build, checks
from xicm.core.results.atomic import write_json_atomic
from xicm.core.execution.episode_runner import episode_runner
from xicm.core.assembly.plugins import describe_plugins, get_registry
from xicm.core.results.run_dir import ADDED_ON_RESUME, HOW_ON_RESUME, IDENTITY, RunDir, config_fingerprint, episode_keys, identity
from xicm.core.execution.run_loop import run_all_episodes
from xicm.core.results.tracking import Tracker
from xicm.core.results.video import VideoSettings
from xicm.report import summary as report

log = logging.getLogger(__name__)


def run_eval(cfg: DictConfig, out_dir: Path) -> dict[str, Any]:
    registry = get_registry()
    tasks = list(cfg.benchmark.tasks)
    checks.check_run(cfg, registry, tasks)
    video = VideoSettings.from_config(cfg.video, out_dir)
    run_dir = RunDir(out_dir)
    how = registry.how_keys(cfg)  # options that change how the run is done, not what it measures
    added = run_dir.check_same_run(cfg, how)
    if added:
        log.warning(
            "resuming %s with options declared after it started (%s); its earlier episodes ran before they existed",
            out_dir, ", ".join(f"{k}={v}" for k, v in added.items()),
        )
    added = run_dir.added_on_resume(added)  # this resume's and earlier resumes'
    changed = run_dir.how_changed(cfg, how)
    if changed:
        log.info("resuming %s with %s (how it runs, not what it measures)", out_dir,
                 ", ".join(f"{k} {a!r} -> {b!r}" for k, (a, b) in changed.items()))
    how_changes = run_dir.how_on_resume(changed)  # this resume's and earlier resumes'
    out_dir.mkdir(parents=True, exist_ok=True)

    plugins = describe_plugins(registry.pm)
    splits = build.task_splits(registry, tasks)
    keys = episode_keys(tasks, cfg.seeds, cfg.episodes)
    transcripts_dir = out_dir if cfg.transcripts else None
    with episode_runner(
        cfg,
        out_dir,
        keys,
        max_steps=int(cfg.max_steps),
        max_control_steps=cfg.max_control_steps,
        video=video,
        transcripts_dir=transcripts_dir,
        instructions=cfg.benchmark.instructions,
        scene_seed=cfg.benchmark.scene_seed,
    ) as runner:
        run_dir.check_same_metadata(runner.metadata)
        write_json_atomic(
            RunDir(out_dir).meta,
            {
                "fingerprint": config_fingerprint(cfg, how),
                IDENTITY: identity(cfg, how=how),
                **({ADDED_ON_RESUME: added} if added else {}),
                **({HOW_ON_RESUME: how_changes} if how_changes else {}),
                "tasks": tasks,
                "splits": splits,
                **runner.metadata,
                "plugins": plugins,
                "config": OmegaConf.to_container(cfg, resolve=True),
            },
        )
        tracker = Tracker.for_job(cfg, out_dir, config={**OmegaConf.to_container(cfg, resolve=True), "plugins": plugins})
        try:
            rows = run_all_episodes(
                runner.run_one,
                keys,
                out_dir,
                progress=bool(cfg.progress),
                on_result=lambda r: tracker.log({"success": int(r.success), "steps": r.steps, f"task/{r.task}/success": int(r.success)}),
            )
            summary = report.write_report(rows, splits, tasks, out_dir, int(cfg.report.std_ddof))
            _write_html(cfg, out_dir)
            _track_summary(tracker, summary, rows, str(cfg.run_name), f"ours, {cfg.simulator.name}")
            tracker.log_run_media(rows, out_dir)
        finally:
            note = tracker.finish()
            if note:
                print(note)
    return summary


def _write_html(cfg: DictConfig, out_dir: Path) -> None:
    """report.html beside table.md (report.html: false turns it off); a problem here is printed,
    never a failed run: its results are already written."""
    if not cfg.report.html:
        return
    from xicm.report.html_run import write_run_html

    try:
        write_run_html(out_dir, inline_video_mb=float(cfg.report.inline_video_mb))
    except Exception as exc:  # noqa: BLE001
        print(f"report.html not written ({type(exc).__name__}: {exc}); `xicm-report {out_dir} --html` retries it")


def _track_summary(tracker: Tracker, summary: dict[str, Any], rows: list[dict[str, Any]], name: str, source: str) -> None:
    """Success per group in the run's summary, the per-task table, and the paper's Table 2 with
    our row and its per-level bars (tables and a bar chart in the wandb dashboard)."""
    if not tracker.enabled:
        return
    from xicm.report import table2

    tracker.summary({f"success/{g['group']}": g["success"] for g in summary["groups"]})
    tracker.log_table(
        "tasks",
        ["task", "split", "success", "std", "n", "ci_low", "ci_high"],
        [[r["task"], r["split"], r["success"], r["std"], r["n"], r["ci_low"], r["ci_high"]] for r in summary["tasks"]],
    )
    ours = table2.our_row(rows, name, int(summary.get("std_ddof", 1)))
    if ours["groups"]:
        tracker.log_table("table2", *table2.flat_rows(ours, source))
        tracker.log_bars(
            "table2_levels", "level", "success", [(level, round(ours["groups"][level]["success"], 2)) for level in table2.LEVELS if level in ours["groups"]],
            title=f"{name}: success % per level (AGNOSTOS unseen tasks)",
        )
