"""The options of simulator `sapien` (conf/simulator/sapien.yaml), checked before anything is built."""

from dataclasses import dataclass, field
from typing import Any, List

from xicm.core.schema import above, one_of, rule

GRASP_MODES = ("attach", "friction")
SUCCESS_CHECKS = ("per_action", "per_frame")
CAMERA_NAMES = ("front", "left_shoulder", "right_shoulder", "overhead", "wrist")

#: Vulkan guarantees 2D images up to 4096 pixels a side on every device (maxImageDimension2D);
#: measured on lavapipe: one 4096 camera renders (79 s, 6.2 GB), 16385 fails ("cannot create image").
MAX_IMAGE_SIZE = 4096


def _side(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= MAX_IMAGE_SIZE


def _image_size(v: Any) -> bool:
    return _side(v) or (isinstance(v, list) and len(v) == 2 and all(_side(s) for s in v))


def _cameras(v: list) -> bool:
    return len(v) > 0 and len(set(v)) == len(v) and set(v) <= set(CAMERA_NAMES)


@dataclass
class SapienOptions:
    image_size: Any = field(  # an int or [height, width]: OmegaConf has no Union, so the rule checks the type
        default=128,
        metadata=rule(_image_size, f"an integer from 1 to {MAX_IMAGE_SIZE}, or [height, width] of two such integers"),
    )
    cameras: List[str] = field(
        default_factory=lambda: list(CAMERA_NAMES),
        metadata=rule(_cameras, f"a non-empty list of distinct names from {', '.join(CAMERA_NAMES)}"),
    )
    physics_hz: float = field(default=200.0, metadata=above(0))
    control_hz: float = field(default=20.0, metadata=above(0))
    sample_variations: bool = True
    render: bool = True
    lin_speed: float = field(default=0.35, metadata=above(0))  # m/s of the gripper along a straight line
    joint_speed: float = field(default=1.3, metadata=above(0))  # rad/s
    #: attach: RLBench's rigid grasp of a graspable object (grasp.py); friction: finger friction only
    grasp: str = field(default="attach", metadata=one_of(*GRASP_MODES))
    #: per_frame: success read after every control frame, the move ends when it holds (RLBench)
    success_check: str = field(default="per_action", metadata=one_of(*SUCCESS_CHECKS))
