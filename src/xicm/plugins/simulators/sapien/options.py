"""The options of simulator `sapien` (src/xicm/conf/simulator/sapien.yaml), checked before anything is built."""

from dataclasses import dataclass, field
from typing import Any, List

from xicm.core.contracts.schema import above, one_of, rule

from .spec import STEP_MODES

GRASP_MODES = ("attach", "friction")
SUCCESS_CHECKS = ("per_action", "per_frame")
#: ours: each task's own ranges (every scene solvable by its demonstrator); rlbench: RLBench's
#: ranges, and its fixed layouts and success rules where a task names them (Task.rlbench_scenes),
#: each scene redrawn until the task's scripted solution solves it (SapienSimulator.reset_state)
SCENE_RANGES = ("ours", "rlbench")
#: where the Panda stands and how it starts (scene.py ROBOT_PLACEMENTS): ours, or RLBench's as recorded
ROBOTS = ("ours", "rlbench")
#: which key-action targets are refused before a move (SapienSimulator.refused_target): grid: outside
#: the prompt's grid box or below the table top (`unreachable`); rlbench: RLBench's workspace
#: rule where it is known, z from the table top to 1 m above it (`out_of_workspace`), and the grid
#: box's x/y (RLBench's x/y extents come from a shape in its binary scene file: docs/AGNOSTOS.md)
WORKSPACE_CHECKS = ("grid", "rlbench")
CAMERA_NAMES = ("front", "left_shoulder", "right_shoulder", "overhead", "wrist")
#: per-step control modes of `step(action)` (spec.py declares their columns, control_modes.py their maths)
CONTROL_MODES = tuple(STEP_MODES)

#: Vulkan guarantees 2D images up to 4096 pixels a side on every device (maxImageDimension2D);
#: measured on lavapipe: one 4096 camera renders (79 s, 6.2 GB), 16385 fails ("cannot create image").
MAX_IMAGE_SIZE = 4096
DEFAULT_IMAGE_SIZE = 128


def _side(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= MAX_IMAGE_SIZE


def _one_size(v: Any) -> bool:
    return _side(v) or (isinstance(v, list) and len(v) == 2 and all(_side(s) for s in v))


def _image_size(v: Any) -> bool:
    if isinstance(v, dict):
        return len(v) > 0 and set(v) <= set(CAMERA_NAMES) and all(_one_size(s) for s in v.values())
    return _one_size(v)


def sizes_per_camera(image_size: Any, cameras) -> dict[str, tuple[int, int]]:
    """(height, width) of each camera: image_size is an int, [height, width], or a mapping
    camera -> either (cameras it leaves out get DEFAULT_IMAGE_SIZE)."""
    def pair(v: Any) -> tuple[int, int]:
        return (int(v), int(v)) if isinstance(v, int) else (int(v[0]), int(v[1]))

    if isinstance(image_size, dict) or hasattr(image_size, "items"):
        given = dict(image_size.items())
        return {c: pair(given.get(c, DEFAULT_IMAGE_SIZE)) for c in cameras}
    return {c: pair(image_size) for c in cameras}


def _cameras(v: list) -> bool:
    return len(v) > 0 and len(set(v)) == len(v) and set(v) <= set(CAMERA_NAMES)


@dataclass
class SapienOptions:
    """Every option of simulator `sapien`, with its default: the one declaration (sapien.yaml
    repeats them for the command line; tests/test_config_schema.py keeps the two equal)."""

    #: camera resolution: an int (square), [height, width], or camera -> either (cameras it leaves out get 128)
    image_size: Any = field(  # an int, [height, width] or camera -> either: OmegaConf has no Union, so the rule checks the type
        default=DEFAULT_IMAGE_SIZE,
        metadata=rule(
            _image_size,
            f"an integer from 1 to {MAX_IMAGE_SIZE}, or [height, width] of two such integers, or a mapping from "
            f"camera names ({', '.join(CAMERA_NAMES)}) to either",
        ),
    )
    #: the cameras rendered
    cameras: List[str] = field(
        default_factory=lambda: list(CAMERA_NAMES),
        metadata=rule(_cameras, f"a non-empty list of distinct names from {', '.join(CAMERA_NAMES)}"),
    )
    physics_hz: float = field(default=200.0, metadata=above(0))  # physics steps per second of simulated time
    #: frames per second: key moves are followed, recorded and watched by tasks per frame (RLBench: 20 Hz)
    frame_hz: float = field(default=20.0, metadata=above(0))
    #: control steps per second of step(action); frame_hz must be a multiple of it
    control_hz: float = field(default=10.0, metadata=above(0))
    #: the action space of step(action): ee_delta, ee_pose, joint_pos, joint_delta (control_modes.py)
    control_mode: str = field(default="ee_delta", metadata=one_of(*CONTROL_MODES))
    #: read depth / segmentation pictures too (the oracle and grounding_dino detectors need depth,
    #: the oracle segmentation); false skips reading them: CameraFrame.depth / .segmentation are None
    depth: bool = True
    segmentation: bool = True
    render: bool = True  # false: a physics-only simulator (observe() is then unavailable)
    lin_speed: float = field(default=0.35, metadata=above(0))  # m/s of the gripper along a straight line
    joint_speed: float = field(default=1.3, metadata=above(0))  # rad/s
    #: attach: RLBench's rigid grasp of a graspable object (grasp.py); friction: finger friction only
    grasp: str = field(default="attach", metadata=one_of(*GRASP_MODES))
    #: per_frame: success read after every control frame, the move ends when it holds (RLBench)
    success_check: str = field(default="per_action", metadata=one_of(*SUCCESS_CHECKS))
    scenes: str = field(default="ours", metadata=one_of(*SCENE_RANGES))  # SCENE_RANGES above
    robot: str = field(default="ours", metadata=one_of(*ROBOTS))  # ROBOTS above
    #: success_check: per_frame: a move that met success still runs its gripper command, then success
    #: is read once, as X-ICM's RLBench does (false: the command is skipped and success stands)
    gripper_after_success: bool = False
    workspace_check: str = field(default="grid", metadata=one_of(*WORKSPACE_CHECKS))
    #: scenes: rlbench: draws of one episode's scene before it counts as unsolvable
    max_scene_draws: int = field(default=20, metadata=above(0))


def frames_per_step(frame_hz: float, control_hz: float) -> int:
    """Frames in one control step; ConfigError when frame_hz is not a whole multiple of control_hz."""
    ratio = float(frame_hz) / float(control_hz)
    if ratio < 1 - 1e-9 or abs(ratio - round(ratio)) > 1e-9:
        from xicm.core.contracts.errors import ConfigError

        raise ConfigError(
            f"simulator.frame_hz ({frame_hz:g}) must be a whole multiple of simulator.control_hz ({control_hz:g}), "
            "e.g. frame_hz 20 with control_hz 10, 20 or 5"
        )
    return int(round(ratio))


#: options that became other keys: the registry refuses them with a sentence naming the new key
REPLACED = {"sample_variations": "benchmark.variations (zero | sampled)"}


def check_rates(options: dict) -> None:
    """The simulator group's rule between options (core.checks calls it before building)."""
    from xicm.core.assembly.plugins import options_object

    values = options_object(SapienOptions, {k: v for k, v in options.items() if k != "name"})
    frames_per_step(values.frame_hz, values.control_hz)
