"""check_simulator: the Simulator contract checked on a live simulator, in the spirit of
gymnasium's check_env. Any simulator plugin can run it on one of its tasks:

    from xicm.core.contracts.simulator_check import check_simulator
    report = check_simulator(my_simulator, "open_drawer")   # AssertionError (one sentence) on a breach

It checks what the tracks rely on: the catalogue; the same (task, seed, episode) giving the same
scene, with and without rendering; proprio laid out as control_spec().state; the control modes'
widths, bounds and gripper column; rendered cameras at image_sizes(); bad actions and poses
refused with a reason instead of an exception; and a control-rate recording whose actions
replay to success through step(). Optional parts a simulator does not implement
(NotImplementedError) are listed in the report's `skipped`, not failed.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from xicm.core.contracts.interfaces import Simulator
from xicm.core.contracts.spaces import GRIPPER_CLOSED, GRIPPER_OPEN, KEY_JOINTS, KEY_POSE, KEY_POSE_NAMES, ControlSpec
from xicm.core.contracts.types import KeyAction, Observation, TaskInfo


class ContractBreach(AssertionError):
    """The simulator breaks the contract (the message says where)."""


def _require(condition: bool, message: str) -> None:
    if not condition:
        raise ContractBreach(message)


def check_simulator(sim: Simulator, task: str, seed: int = 0, episode: int = 0, render: bool = True,
                    replay: bool = True) -> dict:
    """Check `sim` on `task`; returns {"checked": [...], "skipped": [...]}. `render=False` for a
    simulator built without a renderer (observe() is then not called); `replay=False` skips
    recording and replaying the scripted demo (the slow part)."""
    report: dict[str, list[str]] = {"checked": [], "skipped": []}

    def optional(name: str, call):
        try:
            result = call()
        except NotImplementedError:
            report["skipped"].append(name)
            return None
        report["checked"].append(name)
        return result

    _check_catalogue(sim, task)
    report["checked"].append("catalogue")
    spec = optional("control_spec", sim.control_spec)
    if spec is not None:
        _check_spec(spec)
    _check_same_scene(sim, task, seed, episode, render, spec)
    report["checked"].append("reset")
    if render:
        optional("image_sizes", lambda: _check_cameras(sim))
    if spec is not None and spec.control_mode is not None:
        _check_bad_steps(sim, task, seed, episode, spec)
        report["checked"].append("step refuses bad actions")
    _check_bad_pose(sim, task, seed, episode)
    report["checked"].append("execute refuses a pose outside the workspace")
    if replay:
        optional("record_scripted + replay", lambda: _check_recording(sim, task, seed, episode, spec))
    return report


def _check_catalogue(sim: Simulator, task: str) -> None:
    names = sim.task_names()
    _require(isinstance(names, list) and all(isinstance(n, str) for n in names), "task_names() must return a list of str")
    _require(task in names, f"task_names() does not list {task!r}")
    info = sim.task_info(task)
    _require(isinstance(info, TaskInfo) and info.name == task, f"task_info({task!r}) must return its TaskInfo")
    lo, hi = (np.asarray(v, dtype=float) for v in sim.workspace)
    _require(lo.shape == hi.shape == (3,) and bool(np.all(lo < hi)), "workspace must be (low xyz, high xyz) with low < high")


def _check_spec(spec: ControlSpec) -> None:
    names = spec.mode_names()
    _require(len(set(names)) == len(names) and names, f"control_spec() names its modes once each, got {names}")
    for mode in spec.modes:
        low, high = mode.bounds()
        _require(bool(np.all(low <= high)), f"control mode {mode.name}: a low bound exceeds its high bound")
        _require(low[-1] <= GRIPPER_CLOSED and high[-1] >= GRIPPER_OPEN,
                 f"control mode {mode.name}: the last column is the gripper, bounded by closed {GRIPPER_CLOSED} and open {GRIPPER_OPEN}")
    if KEY_POSE in names:
        _require(spec.mode(KEY_POSE).names == KEY_POSE_NAMES and not spec.mode(KEY_POSE).per_step,
                 f"the {KEY_POSE} mode is {', '.join(KEY_POSE_NAMES)}, played by execute()")
    if KEY_JOINTS in names:
        _require(not spec.mode(KEY_JOINTS).per_step, f"the {KEY_JOINTS} mode is played by execute()")
    if spec.control_mode is not None:
        _require(spec.control_mode in spec.mode_names(per_step=True), f"control_mode {spec.control_mode!r} is not a per-step mode")
        _require(spec.control_hz is not None and spec.control_hz > 0, "a simulator with per-step control gives control_hz > 0")
    fields = [f.name for f in spec.state]
    _require(len(set(fields)) == len(fields), f"control_spec().state names each proprio field once, got {fields}")


def _check_proprio(proprio: dict, spec: ControlSpec | None, where: str) -> None:
    if spec is None:
        return
    _require(list(proprio) == [f.name for f in spec.state],
             f"{where}: proprio fields {list(proprio)} are not control_spec().state's {[f.name for f in spec.state]}")
    for f in spec.state:
        value = np.asarray(proprio[f.name])
        _require(value.shape == (f.width,) and bool(np.all(np.isfinite(value))),
                 f"{where}: proprio {f.name} must be {f.width} finite numbers, got shape {value.shape}")


def _check_same_scene(sim: Simulator, task: str, seed: int, episode: int, render: bool, spec: ControlSpec | None) -> None:
    if render:
        obs = sim.reset(task, seed, episode)
        _require(isinstance(obs, Observation), "reset() must return an Observation")
        _require(obs.instruction == sim.instruction(), "instruction() differs from the reset observation's")
        _check_proprio(obs.proprio, spec, "reset()")
        first, words = {k: np.array(v) for k, v in obs.proprio.items()}, obs.instruction
    else:
        sim.reset_state(task, seed, episode)
        first, words = {k: np.array(v) for k, v in sim.proprio().items()}, sim.instruction()
    variation = sim.variation()
    _require(isinstance(variation, int) and variation >= 0, f"variation() must return an int >= 0, not {variation!r}")
    sim.reset_state(task, seed, episode)
    again = sim.proprio()
    _check_proprio(again, spec, "proprio()")
    _require(sim.instruction() == words, "reset_state() and reset() of the same episode give different instructions")
    _require(sim.variation() == variation, "reset_state() and reset() of the same episode give different variations")
    _require(set(again) == set(first) and all(np.array_equal(again[k], first[k]) for k in first),
             "the same (task, seed, episode) gives different robot states")
    _require(isinstance(sim.is_success(), bool), "is_success() must return a bool")


def _check_cameras(sim: Simulator) -> None:
    sizes = sim.image_sizes()
    _require(bool(sizes), "image_sizes() names no camera")
    names: Sequence[str] = list(sizes)
    obs = sim.observe(names[:1])
    _require(set(obs.cameras) == {names[0]}, f"observe([{names[0]!r}]) must render that camera only, got {sorted(obs.cameras)}")
    rgb = obs.cameras[names[0]].rgb
    _require(rgb.shape == (*sizes[names[0]], 3) and rgb.dtype == np.uint8,
             f"camera {names[0]}: rgb must be uint8 {(*sizes[names[0]], 3)} as image_sizes() says, got {rgb.dtype} {rgb.shape}")


def _check_bad_steps(sim: Simulator, task: str, seed: int, episode: int, spec: ControlSpec) -> None:
    sim.reset_state(task, seed, episode)
    before = sim.proprio()
    width = spec.step_mode.width
    for bad in (np.zeros(width + 1), np.full(width, np.nan)):
        try:
            outcome = sim.step(bad)
        except Exception as exc:  # noqa: BLE001 - the breach is that it raised
            raise ContractBreach(f"step() raised {type(exc).__name__} for a bad action; it must return a failed StepOutcome") from exc
        _require(not outcome.ok and outcome.error_kind == "bad_action" and bool(outcome.error_message),
                 f"step() of a bad action ({bad.shape}, {bad[0]}) must fail with error_kind 'bad_action' and a reason")
    after = sim.proprio()
    _require(all(np.array_equal(after[k], before[k]) for k in before), "a refused step() moved the robot")


def _check_bad_pose(sim: Simulator, task: str, seed: int, episode: int) -> None:
    sim.reset_state(task, seed, episode)
    far = tuple(float(v) + 10.0 for v in np.asarray(sim.workspace[1], dtype=float))
    outcome = sim.execute(KeyAction(far, (1.0, 0.0, 0.0, 0.0), True))
    _require(not outcome.ok and bool(outcome.error_kind) and bool(outcome.error_message),
             "execute() of a pose 10 m outside the workspace must fail with an error_kind and a reason")


def _check_recording(sim: Simulator, task: str, seed: int, episode: int, spec: ControlSpec | None) -> None:
    sim.reset_state(task, seed, episode)
    rec = sim.record_scripted()
    _require(rec.success, f"the scripted demo of {task} (seed {seed}, episode {episode}) must succeed: {rec.error}")
    if spec is None or spec.control_mode is None:
        return
    for mode in spec.mode_names(per_step=True):
        shape = np.shape(rec.actions.get(mode))
        _require(shape == (rec.steps, spec.mode(mode).width),
                 f"record_scripted().actions[{mode!r}] must be ({rec.steps}, {spec.mode(mode).width}), got {shape}")
    for f in spec.state:
        _require(np.shape(rec.proprio[f.name]) == (rec.steps + 1, f.width), f"the recording's proprio {f.name} must have T + 1 rows")
    sim.reset_state(task, seed, episode)
    outcome = None
    for action in rec.actions[spec.control_mode]:
        outcome = sim.step(action)
        _require(outcome.ok, f"replaying the recording in {spec.control_mode}: {outcome.error_message}")
        if outcome.success:
            break
    _require((outcome is not None and outcome.success) or sim.is_success(),
             f"the recording's {spec.control_mode} actions, stepped from the same reset, must succeed")
