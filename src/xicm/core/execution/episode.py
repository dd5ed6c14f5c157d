"""One evaluation episode of any policy: the single path every policy is evaluated through.

    start_episode: obs = simulator.reset(task, seed, episode) with the episode's instruction;
                   policy.reset(task, obs, rng)   (also what a served policy's episode starts with)
    _act_until_done: until success or a budget is spent, carry out policy.act(obs) one by one, then observe

A key action (KeyAction / JointAction) is `simulator.execute`d and counts against max_steps; a
ControlStep (per-step policies: one, or a chunk of several) is `simulator.step`ped and counts
against max_control_steps (None: the task's default, TaskInfo.max_control_steps).
EpisodeResult.steps counts both.

A failed episode never raises: its kind and one-sentence reason go into the EpisodeResult.
"""

from __future__ import annotations

import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from xicm.core.contracts.errors import EpisodeFailure, LLMError
from xicm.core.assembly.instructions import episode_instruction
from xicm.core.contracts.interfaces import Policy, Simulator
from xicm.core.assembly.seeding import episode_rng
from xicm.core.results.transcripts import write_transcript
from xicm.core.contracts.types import ControlStep, EpisodeResult, Observation
from xicm.core.results.video import EpisodeVideo, VideoSettings


def run_episode(
    simulator: Simulator,
    policy: Policy,
    task: str,
    seed: int,
    episode: int,
    max_steps: int = 25,
    max_control_steps: int | None = None,
    video: VideoSettings | None = None,
    transcripts_dir: Path | None = None,
    instructions: str = "agnostos",
    scene_seed: int | None = None,
) -> EpisodeResult:
    """`video`: record the rollout (src/xicm/core/results/video.py); `transcripts_dir`: the run folder under which
    the policy's prompts and replies, if it keeps them (record()["transcript"]), are written;
    `instructions`: benchmark.instructions (src/xicm/core/assembly/instructions.py); `scene_seed`:
    benchmark.scene_seed (None: the scene is drawn from `seed`, else from scene_seed)."""
    result = EpisodeResult(task=task, seed=int(seed), episode=int(episode), success=False, steps=0)
    timings: dict[str, float] = {}
    start = time.perf_counter()
    recorder = None if video is None else EpisodeVideo(video, task, seed, episode)
    try:
        budgets = Budgets(int(max_steps), max_control_steps, simulator, task)
        _act_until_done(simulator, policy, result, budgets, timings, recorder, instructions, scene_seed)
    except EpisodeFailure as failure:
        result.error_kind, result.error_message = failure.kind, failure.message
    except LLMError as exc:
        result.error_kind, result.error_message = exc.kind, str(exc)
    except Exception as exc:  # a bug in a plugin or in our code: record it, keep the run going
        result.error_kind = "internal_error"
        result.error_message = f"{type(exc).__name__}: {exc} | {last_frame(exc)}"
    try:
        record = policy.record()
    except Exception as exc:  # noqa: BLE001
        record = {"extra": {"record_error": f"{type(exc).__name__}: {exc}"}}
    for key in ("retrieved", "prompt_hash", "responses", "extra"):
        if key in record:
            setattr(result, key, record[key])
    timings.update(record.get("timings", {}))
    if recorder is not None:  # never raises: a video problem is only noted in extra
        result.extra = {**result.extra, **recorder.finish(result.success)}
        timings["video"] = recorder.seconds
        moved = "execute" if "execute" in timings else "step"
        if moved in timings:  # pictures taken during a move count as video, not execute / step
            timings[moved] -= recorder.seconds_in_callbacks
    if transcripts_dir is not None and record.get("transcript"):
        result.extra = {**result.extra, **write_transcript(transcripts_dir, task, seed, episode, record["transcript"])}
    result.timings = {k: round(v, 4) for k, v in timings.items()}
    result.timings["total"] = round(time.perf_counter() - start, 4)
    return result


class Budgets:
    """Key actions against max_steps, control steps against max_control_steps."""

    def __init__(self, max_steps: int, max_control_steps: int | None, simulator: Simulator, task: str):
        self.max_steps, self.simulator, self.task = max_steps, simulator, task
        self._max_control = None if max_control_steps is None else int(max_control_steps)
        self.keys = self.controls = 0

    @property
    def max_control_steps(self) -> int:
        if self._max_control is None:  # looked up only when a per-step policy asks
            self._max_control = self.simulator.task_info(self.task).max_control_steps
            if self._max_control is None:
                raise EpisodeFailure(
                    "max_control_steps", f"task {self.task} declares no max_control_steps: set max_control_steps in the config"
                )
        return self._max_control

    def left(self) -> bool:
        return self.keys < self.max_steps and (self.controls == 0 or self.controls < self.max_control_steps)

    def spent(self, action) -> bool:
        if isinstance(action, ControlStep):
            return self.controls >= self.max_control_steps
        return self.keys >= self.max_steps

    def count(self, action) -> None:
        if isinstance(action, ControlStep):
            self.controls += 1
        else:
            self.keys += 1

    def failure(self) -> EpisodeFailure:
        if self.controls and self.controls >= self.max_control_steps:
            return EpisodeFailure("max_control_steps", f"no success within {self.max_control_steps} control steps")
        return EpisodeFailure("max_steps", f"no success within {self.max_steps} key actions")


@dataclass
class EpisodeStart:
    scene: Observation  # the simulator's observation of the reset scene, with the episode's instruction
    first: Observation  # the observation the policy was reset with (scene, or the one given)
    reword: Callable[[Observation], Observation]  # gives any later observation the same instruction


def start_episode(
    simulator: Simulator,
    policy: Policy,
    task: str,
    seed: int,
    episode: int,
    instructions: str = "agnostos",
    *,
    scene_seed: int | None = None,
    observation: Observation | None = None,
    timings: dict[str, float] | None = None,
) -> EpisodeStart:
    """The one episode start, wherever an episode runs (here, an envs=N slot, a Ray actor, a
    served policy): reset the simulator to the scene (task, seed, episode) (or, with
    benchmark.scene_seed, (task, scene_seed, episode)), give the observation the episode's
    instruction (benchmark.instructions: src/xicm/core/assembly/instructions.py), then `policy.on_episode` and
    `policy.reset` with the episode's own random stream (which keeps `seed`). `observation`:
    the policy's first observation when it comes from elsewhere (a served policy's client); it
    gets the same instruction. A failed reset raises EpisodeFailure("sim_error")."""
    t0 = time.perf_counter()
    try:
        obs = simulator.reset(task, seed if scene_seed is None else int(scene_seed), episode)
    except EpisodeFailure:
        raise
    except Exception as exc:
        raise EpisodeFailure("sim_error", f"reset failed: {type(exc).__name__}: {exc}") from exc
    finally:
        if timings is not None:
            timings["reset"] = timings.get("reset", 0.0) + time.perf_counter() - t0
    reword = episode_instruction(simulator, obs, task, seed, episode, instructions)
    scene = reword(obs)
    first = scene if observation is None else reword(observation)
    policy.on_episode(task, seed, episode)
    policy.reset(task, first, episode_rng(seed, task, episode, stream="policy"))
    return EpisodeStart(scene, first, reword)


def _act_until_done(
    simulator: Simulator,
    policy: Policy,
    result: EpisodeResult,
    budgets: Budgets,
    timings: dict,
    video: EpisodeVideo | None,
    instructions: str = "agnostos",
    scene_seed: int | None = None,
) -> None:
    def timed(stage: str, fn, *args):
        t0 = time.perf_counter()
        try:
            return fn(*args)
        finally:
            timings[stage] = timings.get(stage, 0.0) + time.perf_counter() - t0

    start = start_episode(simulator, policy, result.task, result.seed, result.episode, instructions,
                          scene_seed=scene_seed, timings=timings)
    obs, reword = start.first, start.reword
    if video is not None:
        video.start(simulator, obs)
    while budgets.left():
        actions = policy.act(obs)
        if not actions:
            raise EpisodeFailure("no_actions", "the policy returned no action")
        for action in actions:
            if budgets.spent(action):
                break
            if isinstance(action, ControlStep):
                outcome = timed("step", simulator.step, action.values)
            else:
                outcome = timed("execute", simulator.execute, action)
            budgets.count(action)
            result.steps += 1
            if video is not None:
                video.action_done()
            if not outcome.ok:
                raise EpisodeFailure(outcome.error_kind or "sim_error", outcome.error_message or "step failed")
            if outcome.success:
                result.success = True
                return
        if not policy.observes:
            continue  # it reads the true state instead: do not render for nothing
        try:
            obs = reword(timed("observe", simulator.observe))
        except Exception as exc:
            raise EpisodeFailure("sim_error", f"observe failed: {type(exc).__name__}: {exc}") from exc
    raise budgets.failure()


def last_frame(exc: BaseException) -> str:
    """file:line where an exception was raised (kept short for episodes.jsonl)."""
    frames = traceback.extract_tb(exc.__traceback__)
    if not frames:
        return ""
    f = frames[-1]
    return f"{f.filename.rsplit('/', 1)[-1]}:{f.lineno}"
