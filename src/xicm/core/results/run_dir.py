"""The run folder: its layout, finding runs, its episode rows, and what makes two runs the same.

    <run>/episodes.jsonl    one row per finished episode, appended as each ends
    <run>/run.json          config, fingerprint and identity, tasks and splits, plugins (written at start)
    <run>/summary.json, table.md, tasks.csv     the report (rewritten at the end of each job)
    <run>/transcripts/<task>/s<seed>-e<episode:04d>.json       an episode's LLM prompts and replies
    <run>/videos/<task>/s<seed>-e<episode:04d>-PASS.mp4 (-FAIL)  an episode's rollout video
    <run>/.hydra/overrides.yaml                                the job's overrides (Hydra writes it)

Every file here is written with src/xicm/core/results/atomic.py, except episodes.jsonl, which only grows (each
row flushed and fsynced; a row torn by a kill is cut before the next append).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf

from xicm.core.contracts.errors import ConfigError

EPISODES = "episodes.jsonl"
META = "run.json"
SUMMARY = "summary.json"
TABLE = "table.md"
TASKS_CSV = "tasks.csv"
REPORT_FILES = (SUMMARY, TABLE, TASKS_CSV)
TRANSCRIPTS = "transcripts"
VIDEOS = "videos"
HYDRA_OVERRIDES = ".hydra/overrides.yaml"
VERDICTS = {True: "PASS", False: "FAIL"}  # a video's name ends in its episode's outcome

# Config keys that say where or how a run is done, never what it measures: runs that differ only
# in them are the same run. The one list behind the resume fingerprint, merge's check, the sweep
# axes and a multirun job's folder name (src/xicm/conf/config.yaml's exclude_keys resolve to it).
# `pool_path` is not here: pointing it at another pool changes the results.
OUTSIDE_IDENTITY = (
    "paths", "progress", "tracking", "llm_cache", "run_name", "collect", "export", "shards", "video", "transcripts",
    "serve", "envs", "report",
)
GROWS_ON_RESUME = ("seeds", "episodes")
#: run.json facts a resume must match beside the config: the pool's size, and what the retriever's
#: features come from (Retriever.features_key: the same config with other weights ranks otherwise)
RESUME_MUST_MATCH = ("pool_size", "retrieval_features")
IDENTITY = "identity"  # run.json's key for identity(cfg): what a resume compares key by key
HOW_ON_RESUME = "how_on_resume"  # run.json's key: resumes that changed how the run is done (schema.how options)
ADDED_ON_RESUME = "added_on_resume"  # run.json's key: options resumes added, with their values  # re-running a run with more of them extends it
MERGE_MAY_DIFFER = ("benchmark.tasks", "seeds", "episodes")  # merged runs cover different tasks/seeds

FOLDER_NAME_LIMIT = 131  # characters of a multirun job's folder name (the xicm_dirname resolver)


def episode_stem(seed: int, episode: int) -> str:
    return f"s{int(seed)}-e{int(episode):04d}"


def episode_keys(tasks: Iterable[str], seeds: Iterable[int], episodes: int) -> list[tuple[str, int, int]]:
    """Every (task, seed, episode) of a run, seed-major so partial runs cover all tasks."""
    return [(task, int(seed), ep) for seed in seeds for task in tasks for ep in range(int(episodes))]


@dataclass(frozen=True)
class RunDir:
    """One run folder (it need not exist yet)."""

    path: Path

    def __post_init__(self) -> None:
        object.__setattr__(self, "path", Path(self.path))

    # --- layout ------------------------------------------------------------------------------
    @property
    def episodes(self) -> Path:
        return self.path / EPISODES

    @property
    def meta(self) -> Path:
        return self.path / META

    @property
    def summary(self) -> Path:
        return self.path / SUMMARY

    @property
    def table(self) -> Path:
        return self.path / TABLE

    @property
    def tasks_csv(self) -> Path:
        return self.path / TASKS_CSV

    @property
    def hydra_overrides(self) -> Path:
        return self.path / HYDRA_OVERRIDES

    def transcript(self, task: str, seed: int, episode: int) -> Path:
        return self.path / TRANSCRIPTS / task / f"{episode_stem(seed, episode)}.json"

    def video(self, task: str, seed: int, episode: int, success: bool) -> Path:
        return self.path / VIDEOS / task / f"{episode_stem(seed, episode)}-{VERDICTS[bool(success)]}.mp4"

    def video_recording(self, task: str, seed: int, episode: int) -> Path:
        """Where a video is written while its episode runs (renamed to `video()` at the end)."""
        return self.path / VIDEOS / task / f"{episode_stem(seed, episode)}.recording.mp4"

    def finished_videos(self, task: str, seed: int, episode: int) -> list[Path]:
        return sorted((self.path / VIDEOS / task).glob(f"{episode_stem(seed, episode)}-*.mp4"))

    def relative(self, path: Path) -> str:
        """`path` as episode rows and table.md name it: relative to the run folder, with '/'."""
        return Path(path).relative_to(self.path).as_posix()

    # --- contents ------------------------------------------------------------------------------
    def is_run(self) -> bool:
        return self.episodes.is_file() and self.meta.is_file()

    def read_meta(self) -> dict[str, Any]:
        return json.loads(self.meta.read_text(encoding="utf-8"))

    def read_episodes(self) -> list[dict[str, Any]]:
        """The complete rows of episodes.jsonl ([] if none); a torn last line (killed mid-write) is dropped."""
        if not self.episodes.exists():
            return []
        rows = []
        for line in self.episodes.read_text(encoding="utf-8").splitlines():
            line = line.strip()
            if not line:
                continue
            try:
                rows.append(json.loads(line))
            except json.JSONDecodeError:
                continue
        return rows

    def corrupt_episode_lines(self) -> list[int]:
        """Line numbers (from 1) of episodes.jsonl lines that read_episodes drops but a kill cannot
        explain: every line ended by a newline that is not one JSON object. (A torn last line, with
        no newline after it, is a killed write and is not listed.)"""
        if not self.episodes.exists():
            return []
        lines = self.episodes.read_text(encoding="utf-8").split("\n")[:-1]  # the text after the last newline is the tail
        bad = []
        for number, line in enumerate(lines, 1):
            if not line.strip():
                continue
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                row = None
            if not isinstance(row, dict):
                bad.append(number)
        return bad

    def rows(self, meta: dict[str, Any] | None = None) -> list[dict[str, Any]]:
        """The episodes its config asks for (run.json's tasks, seeds and episodes).

        The file can hold more: a run resumed with fewer episodes or seeds keeps the rows of the
        earlier, larger one. Reports count only the configured ones, as xicm-eval does.
        """
        meta = self.read_meta() if meta is None else meta
        rows = self.read_episodes()
        config = meta.get("config") or {}
        if "seeds" not in config or "episodes" not in config:
            return rows
        keys = set(episode_keys(meta["tasks"], config["seeds"], config["episodes"]))
        return [r for r in rows if (r["task"], int(r["seed"]), int(r["episode"])) in keys]

    @contextlib.contextmanager
    def appending_episodes(self) -> Iterator[Callable[[dict[str, Any]], None]]:
        """append(row) adds one line to episodes.jsonl, flushed and fsynced before it returns.
        A partial last line left by a killed run is cut first, so the next row starts a line."""
        self.path.mkdir(parents=True, exist_ok=True)
        self._cut_torn_tail()
        with open(self.episodes, "a", encoding="utf-8") as f:

            def append(row: dict[str, Any]) -> None:
                f.write(json.dumps(row, ensure_ascii=False) + "\n")
                f.flush()
                os.fsync(f.fileno())

            yield append

    def _cut_torn_tail(self) -> None:
        if not self.episodes.exists() or self.episodes.stat().st_size == 0:
            return
        data = self.episodes.read_bytes()
        if data.endswith(b"\n"):
            return
        with open(self.episodes, "r+b") as f:
            f.truncate(data.rfind(b"\n") + 1)

    def check_same_run(self, cfg: DictConfig | dict[str, Any], how: Iterable[str] = ()) -> dict[str, Any]:
        """Refuse to mix episodes of two different configs in one folder (ConfigError naming the
        keys that differ). A config that only adds keys the run's config did not have (options
        declared after the run started) resumes it: those keys and their values are returned,
        so the caller can say so; {} when nothing was added. `how`: dotted keys of options that
        say how the run is done (Registry.how_keys), never compared, even where an earlier
        run.json holds them in its identity."""
        if not self.meta.exists():
            return {}
        how = tuple(how)
        meta = self.read_meta()
        old_print, new_print = meta.get("fingerprint"), config_fingerprint(cfg, how)
        if old_print == new_print:
            return {}
        # run.json files written before IDENTITY existed hold only the resolved config
        old = meta.get(IDENTITY)
        new = identity(cfg, resolve=old is None, how=how)
        old = identity(meta.get("config") or {}, how=how) if old is None else {k: v for k, v in old.items() if not outside_identity(k, how)}
        changed = [f"{k} {old[k]!r} -> {new[k]!r}" for k in sorted(old.keys() & new.keys()) if old[k] != new[k]]
        changed += [f"{k} {old[k]!r} -> (absent)" for k in sorted(old.keys() - new.keys())]
        if changed or not old:
            shown = "; ".join(changed[:5]) + (f"; and {len(changed) - 5} more" if len(changed) > 5 else "")
            raise ConfigError(
                f"{self.path} holds episodes of a different config (fingerprint {old_print} != {new_print}"
                f"{': ' + shown if shown else ''}); choose another output folder with hydra.run.dir=... or delete that one"
            )
        return {k: new[k] for k in sorted(new.keys() - old.keys())}

    def how_changed(self, cfg: DictConfig | dict[str, Any], how: Iterable[str]) -> dict[str, list[Any]]:
        """The `how` keys whose values this start changes against run.json's config, as
        {key: [earlier, now]} (resolved values, so `${envs}` reads as its number); {} for a new run."""
        if not self.meta.exists():
            return {}
        before = flatten(self.read_meta().get("config") or {})
        now = flatten(OmegaConf.to_container(cfg, resolve=True) if isinstance(cfg, DictConfig) else dict(cfg))
        return {k: [before[k], now.get(k)] for k in how if k in before and before[k] != now.get(k)}

    def how_on_resume(self, changed: dict[str, list[Any]]) -> list[dict[str, Any]]:
        """run.json's HOW_ON_RESUME, with this start's `changed` (from how_changed) appended as
        {"episodes_before": rows written before it, "changed": changed} when there is one."""
        earlier = list(self.read_meta().get(HOW_ON_RESUME) or []) if self.meta.exists() else []
        return earlier + ([{"episodes_before": len(self.read_episodes()), "changed": changed}] if changed else [])

    def check_same_metadata(self, metadata: dict[str, Any], keys: Iterable[str] = RESUME_MUST_MATCH) -> None:
        """Refuse a resume whose run metadata differs from what run.json recorded for `keys`
        (e.g. a retriever's features made by other weights under the same config); a key the
        earlier run did not record is not compared."""
        if not self.meta.exists():
            return
        meta = self.read_meta()
        for key in keys:
            if key in meta and key in metadata and meta[key] != metadata[key]:
                raise ConfigError(
                    f"{self.path} holds episodes run with {key} {meta[key]!r}, this run has {metadata[key]!r} "
                    "(the same config, other weights or data); restore those, or choose another output folder"
                )

    def added_on_resume(self, added: dict[str, Any]) -> dict[str, Any]:
        """`added` (from check_same_run) joined to what earlier resumes of this run added."""
        earlier = (self.read_meta().get(ADDED_ON_RESUME) or {}) if self.meta.exists() else {}
        return {**earlier, **added}


def video_passed(path: str | Path) -> bool:
    """Whether a video's name says its episode succeeded."""
    return str(path).endswith(f"-{VERDICTS[True]}.mp4")


def find_runs(root: Path) -> list[Path]:
    """Every run folder at or under `root` (one with both episodes.jsonl and run.json), sorted."""
    return sorted(p.parent for p in Path(root).rglob(EPISODES) if RunDir(p.parent).is_run())


# --- identity --------------------------------------------------------------------------------
def override_key(override: str) -> str:
    """The config key of a Hydra override: `+tracking.mode=x` -> `tracking.mode`."""
    return override.split("=", 1)[0].lstrip("+~").split("@", 1)[0]


def outside_identity(key: str, also: Iterable[str] = ()) -> bool:
    """Whether the dotted config key (or an override's key) is in OUTSIDE_IDENTITY or `also`,
    or below one of them."""
    key = override_key(key)
    return any(key == k or key.startswith(k + ".") for k in (*OUTSIDE_IDENTITY, *also))


def overrides_outside_identity(overrides: Iterable[str]) -> list[str]:
    """The keys of those overrides that are outside a run's identity: src/xicm/conf/config.yaml's
    hydra exclude_keys (Hydra compares override keys exactly, so they are listed one by one)."""
    return [override_key(o) for o in overrides if outside_identity(o)]


def config_fingerprint(cfg: DictConfig | dict[str, Any], how: Iterable[str] = ()) -> str:
    """Hash of the run's identity (the unresolved config without the keys outside identity, those
    that grow on resume and the `how` keys: Registry.how_keys)."""
    kept = identity(cfg, how=how)
    return hashlib.sha256(json.dumps(kept, sort_keys=True, default=str).encode()).hexdigest()[:16]


def flatten(data: Any, prefix: str = "") -> dict[str, Any]:
    """A nested config as {dotted.key: value}; lists become their JSON text."""
    if isinstance(data, dict):
        out: dict[str, Any] = {}
        for key, value in data.items():
            out.update(flatten(value, f"{prefix}{key}."))
        return out
    return {prefix[:-1]: json.dumps(data) if isinstance(data, list) else data}


def identity(cfg: DictConfig | dict[str, Any], resolve: bool = False, how: Iterable[str] = ()) -> dict[str, Any]:
    """The config's keys that make a run what it is, as {dotted.key: value} (run.json's IDENTITY:
    unresolved, so `${paths.cache}/...` reads the same on every machine), without the `how` keys."""
    data = OmegaConf.to_container(cfg, resolve=resolve) if isinstance(cfg, DictConfig) else dict(cfg)
    return {k: v for k, v in flatten(data).items() if not outside_identity(k, (*GROWS_ON_RESUME, *how))}


def short_name(text: str, limit: int) -> str:
    """`text` if at most `limit` characters, else its start and a hash of the whole, `limit`
    characters in all (long names stay distinct): folder names and wandb labels."""
    text = str(text)
    if len(text) <= limit:
        return text
    return f"{text[: limit - 11]}-{hashlib.sha1(text.encode()).hexdigest()[:10]}"
