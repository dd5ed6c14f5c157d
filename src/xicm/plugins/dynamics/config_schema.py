"""The schema of src/xicm/conf/train_dynamics.yaml (Hydra structured config `train_dynamics_schema`), as
core's is for config.yaml: types checked when Hydra composes, rules by `check_config` before
the training starts. Values live in the YAML files; the field order is the composed order."""

from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional

from omegaconf import MISSING

from xicm.core.assembly.config_schema import Paths
from xicm.core.contracts.schema import above, at_least, one_of, rule

TARGETS = ("residual", "frame")  # what the model learns: the change of the frame, or the frame
PREDICTIONS = ("epsilon", "v_prediction", "sample")  # what the UNet outputs


def _step_counts(v: Any) -> bool:
    counts = v if isinstance(v, list) else [v]
    return len(counts) > 0 and all(isinstance(c, int) and not isinstance(c, bool) and c >= 1 for c in counts)


@dataclass
class DynamicsModel:
    target: str = field(default=MISSING, metadata=one_of(*TARGETS))
    prediction: str = field(default=MISSING, metadata=one_of(*PREDICTIONS))
    resolution: int = field(default=MISSING, metadata=at_least(1))
    block_out_channels: List[int] = field(
        default=MISSING, metadata=rule(lambda v: len(v) > 0 and min(v) >= 1, "a non-empty list of integers >= 1")
    )
    cross_attention: List[bool] = MISSING  # one per block (checked when the UNet is built)
    layers_per_block: int = field(default=MISSING, metadata=at_least(1))
    attention_head_dim: int = field(default=MISSING, metadata=at_least(1))
    norm_num_groups: int = field(default=MISSING, metadata=at_least(1))


@dataclass
class Train:
    steps: int = field(default=MISSING, metadata=at_least(1))
    batch_size: int = field(default=MISSING, metadata=at_least(1))
    lr: float = field(default=MISSING, metadata=above(0))
    weight_decay: float = field(default=MISSING, metadata=at_least(0))
    warmup_steps: int = field(default=MISSING, metadata=at_least(0))
    num_train_timesteps: int = field(default=MISSING, metadata=at_least(1))
    seed: int = MISSING
    heldout_every: int = field(default=MISSING, metadata=at_least(0))  # 0 or 1: nothing held out
    checkpoint_every: int = field(default=MISSING, metadata=at_least(1))
    keep_checkpoints: int = field(default=MISSING, metadata=at_least(1))
    log_every: int = field(default=MISSING, metadata=at_least(1))
    threads: Optional[int] = field(default=MISSING, metadata=at_least(1))


@dataclass
class Evaluation:
    sample_steps: Any = field(  # a count or a list of them: OmegaConf has no Union
        default=MISSING, metadata=rule(_step_counts, "a DDIM step count >= 1 or a non-empty list of them")
    )
    seed: int = MISSING
    batch_size: int = field(default=MISSING, metadata=at_least(1))
    num_images: int = field(default=MISSING, metadata=at_least(1))


@dataclass
class Tracking:
    mode: str = field(default=MISSING, metadata=one_of("offline", "online", "disabled"))
    project: str = MISSING


@dataclass
class TrainDynamicsConfig:
    dynamics_model: DynamicsModel = field(default_factory=DynamicsModel)
    pool: str = MISSING
    tasks: Optional[List[str]] = MISSING
    paths: Paths = field(default_factory=Paths)
    pool_path: str = MISSING
    out_dir: str = MISSING
    text_encoder: Dict[str, Any] = MISSING  # kind + its options (checked by src/xicm/plugins/dynamics/text.py)
    train: Train = field(default_factory=Train)
    evaluation: Evaluation = field(default_factory=Evaluation)
    tracking: Tracking = field(default_factory=Tracking)
    progress: bool = MISSING
    run_name: str = MISSING


def store_schema() -> None:
    """Put the schema into Hydra's ConfigStore as `train_dynamics_schema` (train_dynamics.yaml's first default)."""
    from hydra.core.config_store import ConfigStore

    ConfigStore.instance().store(name="train_dynamics_schema", node=TrainDynamicsConfig)
