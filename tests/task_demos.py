"""Helpers of the SAPIEN task tests: drive a task's own scripted demonstrator, or a changed copy
of it, in the test's simulator (`sim` fixture, conftest.py)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from xicm.core.contracts.types import KeyAction


def go(sim, action: KeyAction) -> None:
    """Execute one key action, which must be reachable."""
    assert sim.execute(action).ok


def run_demo(sim, change=None) -> None:
    """Execute the current task's demonstration (its key poses depend on the state as it goes);
    `change(i, action)` may replace key action i."""
    for i, action in enumerate(sim.task.demonstration()):
        go(sim, action if change is None else change(i, action))


def run_demo_aimed(sim, attribute: str, value) -> None:
    """Execute the demonstration with the task attribute the demonstrator aims by (its variation,
    target, ...) set to `value`, then restore the real one."""
    real = getattr(sim.task, attribute)
    setattr(sim.task, attribute, value)
    try:
        run_demo(sim)
    finally:
        setattr(sim.task, attribute, real)


def moved(action: KeyAction, dxyz=(0.0, 0.0, 0.0), gripper_open: bool | None = None) -> KeyAction:
    """The key action shifted by dxyz (metres), optionally with another gripper state."""
    position = tuple(float(p + d) for p, d in zip(action.position, dxyz))
    grip = action.gripper_open if gripper_open is None else gripper_open
    return dataclasses.replace(action, position=position, gripper_open=grip)


def shifted(after: int, offset):
    """A `change` for run_demo that moves every key action from index `after` on by `offset` metres."""
    return lambda i, action: action if i < after else moved(action, offset)


def hold_at_release(sim) -> KeyAction:
    """Run the demonstration up to its first release (the gripper opening while closed), go to
    that pose keeping the gripper closed, and return the release key action."""
    for action in sim.task.demonstration():
        if action.gripper_open and not sim.robot.gripper_open:
            go(sim, moved(action, gripper_open=False))
            return action
        go(sim, action)
    pytest.fail("the demonstrator never let go")


PAPER_SIMULATOR = Path(__file__).resolve().parents[1] / "src/xicm/conf" / "simulator" / "sapien_paper.yaml"


def paper_simulator(**changes):
    """A fresh physics-only SAPIEN simulator with the paper settings (src/xicm/conf/simulator/sapien_paper.yaml:
    RLBench's scenes, robot and success check), `changes` applied on top."""
    from omegaconf import OmegaConf

    from xicm.core.assembly.plugins import get_registry

    options = {k: v for k, v in OmegaConf.to_container(OmegaConf.load(PAPER_SIMULATOR)).items() if k != "defaults"}
    options.update({"name": "sapien", "render": False, **changes})
    return get_registry().create_simulator(options)


@pytest.fixture
def paper_sim():
    """paper_simulator() for one test (import it into the test module to use it)."""
    simulator = paper_simulator()
    yield simulator
    simulator.close()
