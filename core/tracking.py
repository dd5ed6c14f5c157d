"""wandb tracking: one run per Hydra job; offline by default, 'disabled' in tests."""

from __future__ import annotations

import os
from typing import Any


class Tracker:
    """Thin wrapper so the rest of the code never imports wandb itself."""

    def __init__(self, mode: str, project: str, run_name: str, out_dir: str, config: dict[str, Any], tags: list[str] | None = None):
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
            tags=tags or [],
            reinit="finish_previous",
            settings=wandb.Settings(silent=True),
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
        return f"wandb ({mode}): {where}" + (" (upload with `wandb sync` on that folder)" if mode == "offline" else "")
