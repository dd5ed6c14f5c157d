"""xicm-eval's job: build the plugins from the config, run the episodes, write the report."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf

from xicm.core import build, report
from xicm.core.atomic import write_json_atomic
from xicm.core.episode_loop import run_episodes
from xicm.core.plugins import describe_plugins, get_registry
from xicm.core.ray_shards import episode_runner, shard_settings
from xicm.core.run_dir import RunDir, config_fingerprint, episode_keys
from xicm.core.tracking import Tracker
from xicm.core.video import VideoSettings


def run_eval(cfg: DictConfig, out_dir: Path) -> dict[str, Any]:
    registry = get_registry()
    tasks = list(cfg.benchmark.tasks)
    build.check_run(cfg, registry, tasks)
    shards = shard_settings(cfg)
    video = VideoSettings.from_config(cfg, out_dir)
    RunDir(out_dir).check_same_run(cfg)
    out_dir.mkdir(parents=True, exist_ok=True)

    plugins = describe_plugins(registry.pm)
    splits = build.task_splits(registry, tasks)
    keys = episode_keys(tasks, cfg.seeds, cfg.episodes)
    transcripts_dir = out_dir if cfg.get("transcripts", True) else None
    with episode_runner(
        shards,
        cfg,
        out_dir,
        keys,
        max_steps=int(cfg.max_steps),
        video=video,
        transcripts_dir=transcripts_dir,
        instructions=str(cfg.benchmark.get("instructions", "agnostos")),
    ) as runner:
        write_json_atomic(
            RunDir(out_dir).meta,
            {
                "fingerprint": config_fingerprint(cfg),
                "tasks": tasks,
                "splits": splits,
                **runner.metadata,
                "plugins": plugins,
                "config": OmegaConf.to_container(cfg, resolve=True),
            },
        )
        tracker = Tracker.for_job(cfg, out_dir, config={**OmegaConf.to_container(cfg, resolve=True), "plugins": plugins})
        try:
            rows = run_episodes(
                runner.run_one,
                keys,
                out_dir,
                progress=bool(cfg.progress),
                on_result=lambda r: tracker.log({"success": int(r.success), "steps": r.steps, f"task/{r.task}/success": int(r.success)}),
            )
            summary = report.write_report(rows, splits, tasks, out_dir)
            _track_summary(tracker, summary)
            tracker.log_run_media(rows, out_dir)
        finally:
            note = tracker.finish()
            if note:
                print(note)
    return summary


def _track_summary(tracker: Tracker, summary: dict[str, Any]) -> None:
    tracker.summary({f"success/{g['group']}": g["success"] for g in summary["groups"]})
    tracker.log_table(
        "tasks",
        ["task", "split", "success", "std", "n", "ci_low", "ci_high"],
        [[r["task"], r["split"], r["success"], r["std"], r["n"], r["ci_low"], r["ci_high"]] for r in summary["tasks"]],
    )
