"""Replaying a demonstration's key actions (read with xicm.core.text.encoding's key-frame rule),
and a control-rate recording's per-step actions (`replay_steps`).

X-ICM only works if the key actions of a scripted demonstration, quantised to the 1 cm /
5 degree text grid, solve the task again when executed one by one; the tests and
benchmarks/scripted_success.py check that with `replay_demo`.
"""

from __future__ import annotations

from xicm.core.text import encoding
from xicm.core.contracts.types import ControlRecording, KeyAction, Trajectory

from .control_modes import actions as recording_actions


def demo_key_actions(traj: Trajectory, workspace=None) -> list[KeyAction]:
    """Key actions at the trajectory's key frames, quantised when `workspace` is given."""
    actions = encoding.key_actions_from_trajectory(traj)
    if workspace is not None:
        actions = [encoding.quantise(a, workspace) for a in actions]
    return actions


def replay(sim, task: str, seed: int, episode: int, actions: list[KeyAction]) -> tuple[bool, str | None]:
    """Reset the episode (physics only) and execute the actions until success.

    Returns (success, error message of the step that failed or None).
    """
    sim.reset_state(task, seed, episode)
    for action in actions:
        outcome = sim.execute(action)
        if not outcome.ok:
            return False, outcome.error_message
        if outcome.success:
            return True, None
    return sim.is_success(), None


def replay_demo(sim, task: str, seed: int, episode: int, quantised: bool = True) -> tuple[bool, bool, int]:
    """Demonstrate an episode, then replay its key actions: (demo success, replay success, #keys)."""
    sim.reset_state(task, seed, episode)
    traj = sim.demonstrate()
    actions = demo_key_actions(traj, sim.workspace if quantised else None)
    ok, _ = replay(sim, task, seed, episode, actions)
    return bool(traj.success), ok, len(actions)


def replay_steps(sim, recording: ControlRecording, mode: str) -> tuple[bool, str | None]:
    """Reset the recording's episode (physics only) and step its actions in `mode` until success.

    Returns (success, error message of the step that failed or None)."""
    sim.control_mode = mode
    sim.reset_state(recording.task, recording.seed, recording.episode)
    for action in recording_actions(recording, mode):
        outcome = sim.step(action)
        if not outcome.ok:
            return False, outcome.error_message
        if outcome.success:
            return True, None
    return sim.is_success(), None
