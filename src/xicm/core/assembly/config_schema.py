"""The schema of src/xicm/conf/config.yaml's own keys (Hydra structured config `xicm_schema`).

src/xicm/conf/config.yaml lists `xicm_schema` first in its defaults, so Hydra composes onto these
dataclasses: a value of the wrong type stops at compose time, and `check_config` checks the
rules (ranges, choices) after it. Values live in the YAML only (fields here are MISSING);
the field order is the composed config's key order, which run.json keeps. The plugin groups
are mappings here: each plugin checks its own options (register(..., options=...)).
"""

from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional

from omegaconf import MISSING

from xicm.core.assembly.instructions import INSTRUCTION_CHOICES
from xicm.core.contracts.schema import above, at_least, between, number, one_of, rule

#: episode_rng keeps 32 bits of a seed (xicm.core.assembly.seeding), so larger or negative seeds would
#: repeat the scenes of another seed.
SEED_MAX = 2**32 - 1


def _seed_list(v: list) -> bool:
    return len(v) > 0 and len(set(v)) == len(v) and all(0 <= s <= SEED_MAX for s in v)


def _workers(v: Any) -> bool:
    return v == "auto" or (isinstance(v, int) and not isinstance(v, bool) and v >= 1)


def _names(v: list) -> bool:
    return len(v) > 0 and len(set(v)) == len(v)


Group = Dict[str, Any]  # a plugin's options, checked against the plugin's own schema


@dataclass
class Paths:
    data: str = MISSING
    cache: str = MISSING


@dataclass
class Collect:
    demos_per_task: int = field(default=MISSING, metadata=at_least(1))
    seed: int = field(default=MISSING, metadata=rule(lambda v: 0 <= v <= SEED_MAX, f"an integer from 0 to {SEED_MAX}"))
    max_attempts_factor: Any = field(default=MISSING, metadata=number(1))  # attempts per demo wanted
    workers: Any = field(default=MISSING, metadata=rule(_workers, "'auto' or an integer >= 1"))


@dataclass
class Export:
    """xicm-export (xicm.export): scripted demos recorded at the control rate -> a LeRobot dataset."""

    tasks: Optional[List[str]] = field(  # null: the seen benchmark's tasks
        default=MISSING, metadata=rule(lambda v: v is None or _names(v), "null or a non-empty list of distinct task names")
    )
    demos_per_task: int = field(default=MISSING, metadata=at_least(1))
    seed: int = field(default=MISSING, metadata=rule(lambda v: 0 <= v <= SEED_MAX, f"an integer from 0 to {SEED_MAX}"))
    max_attempts_factor: Any = field(default=MISSING, metadata=number(1))
    workers: Any = field(default=MISSING, metadata=rule(_workers, "'auto' or an integer >= 1"))
    cameras: List[str] = field(default=MISSING, metadata=rule(_names, "a non-empty list of distinct camera names"))
    frames: str = field(default=MISSING, metadata=one_of("control", "key"))
    out_dir: str = MISSING
    repo_id: str = field(default=MISSING, metadata=rule(lambda v: v.count("/") == 1 and "" not in v.split("/"), "'owner/name'"))
    use_videos: bool = MISSING
    vcodec: str = field(default=MISSING, metadata=one_of("libsvtav1", "h264", "hevc"))


@dataclass
class LLMCache:
    enabled: bool = MISSING
    path: str = MISSING


@dataclass
class Tracking:
    mode: str = field(default=MISSING, metadata=one_of("offline", "online", "disabled"))
    project: str = MISSING
    group: Optional[str] = MISSING


@dataclass
class Video:
    enabled: bool = MISSING
    camera: str = field(default=MISSING, metadata=rule(lambda v: v != "", "a camera name (a non-empty string)"))
    fps: Any = field(default=MISSING, metadata=number(0, strict=True))
    every: int = field(default=MISSING, metadata=at_least(1))


@dataclass
class Report:
    html: bool = MISSING
    inline_video_mb: Any = field(default=MISSING, metadata=number(0))
    std_ddof: int = field(default=MISSING, metadata=between(0, 1))


@dataclass
class Shards:
    backend: str = field(default=MISSING, metadata=one_of("local", "ray"))
    workers: int = field(default=MISSING, metadata=at_least(1))
    address: Optional[str] = MISSING
    cpus_per_worker: Any = field(default=MISSING, metadata=number(0, strict=True))  # Ray takes fractions


@dataclass
class Serve:
    host: str = MISSING
    port: int = field(default=MISSING, metadata=rule(lambda v: 0 <= v <= 65535, "a port number from 0 to 65535 (0: any free port)"))
    sessions: int = field(default=MISSING, metadata=at_least(1))
    max_sessions: int = field(default=MISSING, metadata=at_least(1))
    idle_timeout_s: Optional[float] = field(default=MISSING, metadata=above(0))
    api_key_env: Optional[str] = MISSING


@dataclass
class Benchmark:
    name: str = MISSING
    tasks: List[str] = field(default=MISSING, metadata=rule(_names, "a non-empty list of distinct task names"))
    pool: str = MISSING
    pool_tasks: List[str] = MISSING
    #: zero: every episode on variation 0; sampled: a variation per episode from its seed (as in
    #: collection); sets the simulator's sample_variations (src/xicm/core/contracts/interfaces.py)
    variations: str = field(default=MISSING, metadata=one_of("zero", "sampled"))
    #: agnostos: each task's AGNOSTOS instruction; sampled: one of its variation-0 phrasings per
    #: episode, drawn from the episode's seed stream (language-robustness studies)
    instructions: str = field(default=MISSING, metadata=one_of(*INSTRUCTION_CHOICES))
    #: null: each seed draws its own scenes; a seed: every seed replays this seed's scenes (episode e
    #: of task t is the same scene under every seed, as X-ICM replays 25 stored scenes), while the
    #: policy's random draws (e.g. retriever=random) still follow the run's seed
    scene_seed: Optional[int] = field(
        default=MISSING, metadata=rule(lambda v: v is None or 0 <= v <= SEED_MAX, f"null or an integer from 0 to {SEED_MAX}")
    )


@dataclass
class XicmConfig:
    simulator: Group = MISSING
    detector: Group = MISSING
    encoder: Group = MISSING
    retriever: Group = MISSING
    prompt: Group = MISSING
    llm: Group = MISSING
    seeds: List[int] = field(
        default=MISSING,
        metadata=rule(_seed_list, f"a non-empty list of distinct integers from 0 to {SEED_MAX}, e.g. [0,1,2]"),
    )
    episodes: int = field(default=MISSING, metadata=at_least(1))
    max_steps: int = field(default=MISSING, metadata=at_least(1))
    max_control_steps: Optional[int] = field(default=None, metadata=at_least(1))
    paths: Paths = field(default_factory=Paths)
    pool_path: str = MISSING
    collect: Collect = field(default_factory=Collect)
    export: Export = field(default_factory=Export)
    llm_cache: LLMCache = field(default_factory=LLMCache)
    tracking: Tracking = field(default_factory=Tracking)
    video: Video = field(default_factory=Video)
    transcripts: bool = MISSING
    report: Report = field(default_factory=Report)
    shards: Shards = field(default_factory=Shards)
    serve: Serve = field(default_factory=Serve)
    envs: int = field(default=MISSING, metadata=at_least(1))
    progress: bool = MISSING
    run_name: str = MISSING
    policy: Group = MISSING
    benchmark: Benchmark = field(default_factory=Benchmark)


def store_schema() -> None:
    """Put the schema into Hydra's ConfigStore as `xicm_schema` (src/xicm/conf/config.yaml's first default)."""
    from hydra.core.config_store import ConfigStore

    ConfigStore.instance().store(name="xicm_schema", node=XicmConfig)
