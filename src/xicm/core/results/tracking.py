"""wandb tracking: one run per Hydra job, grouped by experiment; offline by default, 'disabled' in tests.

A sweep's jobs share a wandb group (`tracking.group`: the `+experiment=NAME` preset, otherwise
the benchmark), and each job's overrides become its job type and tags, so the wandb UI can
group and filter them the way xicm-report's sweep table does.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from xicm.core.results.run_dir import outside_identity, short_name

WANDB_LABEL_LIMIT = 64  # wandb refuses longer tags (and job types)
WANDB_GROUP_LIMIT = 128


def current_job_overrides() -> list[str]:
    """This process's Hydra job's `key=value` overrides (command line and sweep), without the
    keys outside a run's identity (paths, progress, ...: left out of its folder name too);
    [] outside a Hydra job."""
    try:
        from hydra.core.hydra_config import HydraConfig
    except ImportError:
        return []
    if not HydraConfig.initialized():
        return []
    return [o for o in HydraConfig.get().overrides.task if not outside_identity(o)]


class Tracker:
    """Thin wrapper so the rest of the code never imports wandb itself."""

    def __init__(
        self,
        mode: str,
        project: str,
        run_name: str,
        out_dir: str,
        config: dict[str, Any],
        tags: list[str] | None = None,
        group: str | None = None,
        job_type: str | None = None,
    ):
        self._run = None
        if mode == "disabled" or os.environ.get("WANDB_MODE") == "disabled":
            return
        import wandb

        self._wandb = wandb
        self._run = wandb.init(
            project=project,
            name=run_name,
            dir=out_dir,
            mode=mode,
            config=config,
            group=short_name(group, WANDB_GROUP_LIMIT) if group else None,
            job_type=short_name(job_type, WANDB_LABEL_LIMIT) if job_type else None,
            tags=[short_name(t, WANDB_LABEL_LIMIT) for t in tags or []],
            reinit="finish_previous",
            settings=wandb.Settings(silent=True),
        )

    @classmethod
    def for_job(cls, cfg: Any, out_dir: Path, config: dict[str, Any]) -> Tracker:
        """The tracker of an xicm-eval job: `tracking.*` keys, grouped by `tracking.group`,
        job type and tags from the job's overrides (job type 'eval' when there are none)."""
        tracking = cfg.tracking
        overrides = current_job_overrides()
        return cls(
            mode=str(tracking.mode),
            project=str(tracking.project),
            run_name=str(cfg.run_name),
            out_dir=str(out_dir),
            config=config,
            tags=overrides,
            group=tracking.get("group"),
            job_type=",".join(overrides) or "eval",
        )

    @property
    def enabled(self) -> bool:
        return self._run is not None

    def log(self, metrics: dict[str, Any]) -> None:
        if self._run is not None:
            self._run.log(metrics)

    def log_table(self, key: str, columns: list[str], rows: list[list[Any]]) -> None:
        if self._run is not None:
            self._run.log({key: self._wandb.Table(columns=columns, data=rows)})

    def log_bars(self, key: str, label: str, value: str, bars: list[tuple[str, float]], title: str) -> None:
        """A bar chart (wandb.plot.bar) of (label, value) pairs; its data table is logged under `key` too."""
        if self._run is not None and bars:
            table = self._wandb.Table(columns=[label, value], data=[list(b) for b in bars])
            self._run.log({key: self._wandb.plot.bar(table, label, value, title=title)})

    def log_images(self, paths: Iterable[Path]) -> None:
        """One `plots/<file stem>` image per PNG (the report's plots)."""
        if self._run is not None:
            images = {f"plots/{Path(p).stem}": self._wandb.Image(str(p)) for p in paths}
            if images:
                self._run.log(images)

    def log_videos(self, videos: dict[str, list[Path]]) -> None:
        """Rollout videos, one `videos/<task>` entry per task, captioned with their file names."""
        if self._run is not None and videos:
            self._run.log(
                {
                    f"videos/{task}": [self._wandb.Video(str(p), caption=Path(p).stem, format="mp4") for p in paths]
                    for task, paths in videos.items()
                    if paths
                }
            )

    def log_run_media(self, rows: Iterable[dict[str, Any]], run_dir: Path) -> None:
        """The run folder's plots (*.png) and the rollout videos its episode rows name."""
        if self._run is None:
            return
        run_dir = Path(run_dir)
        self.log_images(sorted(run_dir.glob("*.png")))
        videos: dict[str, list[Path]] = {}
        for row in rows:
            rel = (row.get("extra") or {}).get("video")
            if rel and (run_dir / rel).is_file():
                videos.setdefault(row["task"], []).append(run_dir / rel)
        self.log_videos(videos)

    def summary(self, values: dict[str, Any]) -> None:
        if self._run is not None:
            self._run.summary.update(values)

    def finish(self) -> str | None:
        """End the run; returns a one-line note on where it is (None when disabled)."""
        if self._run is None:
            return None
        mode = self._run.settings.mode
        where = str(self._run.settings.sync_dir)
        self._run.finish()
        self._run = None
        # finish() can return before wandb-core has written the run file (wandb 0.31 offline: 2 of
        # 8 runs held only the file header right after it); teardown waits until it is written
        self._wandb.teardown()
        return f"wandb ({mode}): {where}" + (" (upload with `wandb sync` on that folder)" if mode == "offline" else "")
