"""The abstract classes that plugins implement. Each plugin family has one."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from xicm.core.contracts.spaces import ControlSpec
from xicm.core.contracts.types import (
    Box,
    ControlRecording,
    ControlStep,
    Demo,
    JointAction,
    KeyAction,
    Observation,
    Prompt,
    Query,
    StepOutcome,
    TaskInfo,
    Trajectory,
)



class Simulator(ABC):
    """One simulator, reused across episodes (the first render of a process is slow); a reset
    gives the same episode whatever the process simulated before."""

    #: (low xyz, high xyz) of the box the 100^3 text grid covers, metres, world frame.
    workspace: Box
    #: a task variation per episode sampled from (seed, task, episode), else variation 0
    #: (benchmark.variations sets it; simulators with one variation per task ignore it)
    sample_variations: bool = True

    @abstractmethod
    def task_names(self) -> list[str]:
        """Names of the tasks this simulator can load."""

    @abstractmethod
    def task_info(self, task: str) -> TaskInfo:
        """Split, instruction and object names of a task."""

    @abstractmethod
    def reset(self, task: str, seed: int, episode: int) -> Observation:
        """Load `task` and sample its initial state from (seed, task, episode)."""

    @abstractmethod
    def observe(self, cameras: Sequence[str] | None = None) -> Observation:
        """Render the cameras (only the named ones if given) and return the current observation."""

    @abstractmethod
    def execute(self, action: KeyAction | JointAction) -> StepOutcome:
        """Move to the key pose (or joint target), then set the gripper; never raises for a bad pose."""

    def reset_state(self, task: str, seed: int, episode: int) -> None:
        """reset() without rendering (the same scene). Default: reset() and drop its observation."""
        self.reset(task, seed, episode)

    def instruction(self) -> str:
        """The current episode's instruction (its variation's wording). Default: from observe()."""
        return self.observe(cameras=[]).instruction

    def variation(self) -> int:
        """The current episode's task variation (0, 1, ...: which instruction and targets it
        drew). Default: 0, for simulators with one variation per task."""
        return 0

    def proprio(self) -> dict[str, np.ndarray]:
        """The robot's state now, laid out as control_spec().state (what Observation.proprio
        holds). Default: from observe()."""
        return self.observe(cameras=[]).proprio

    def image_sizes(self) -> dict[str, tuple[int, int]]:
        """(height, width) of each camera observe() can render."""
        raise NotImplementedError(f"{type(self).__name__} does not say its image sizes (image_sizes)")

    def control_spec(self) -> ControlSpec:
        """Its control modes (names, widths, bounds; the one `step` plays), the control rate
        and the proprio layout (xicm.core.contracts.spaces): the one declaration every track reads."""
        raise NotImplementedError(f"{type(self).__name__} declares no control modes (control_spec)")

    def step(self, action: Sequence[float]) -> StepOutcome:
        """Advance one control period towards `action` (a vector in control_spec().control_mode);
        success is checked after it. A bad or unreachable action is a failed StepOutcome with
        its reason (error_kind "bad_action" / "unreachable"), never an exception."""
        raise NotImplementedError(f"{type(self).__name__} has no per-step control (step)")

    def record_scripted(self, cameras: Sequence[str] | None = None) -> ControlRecording:
        """Play the scripted solution from the reset state, recording at the control rate: the
        proprio state, the commanded targets, RGB of `cameras` if given, and the actions that
        replay it through `step` in each per-step control mode (what xicm-export writes)."""
        raise NotImplementedError(f"{type(self).__name__} cannot record scripted demos at the control rate (record_scripted)")

    @abstractmethod
    def is_success(self) -> bool:
        """Whether the current state satisfies the task's success condition."""

    def scripted_solution(self) -> Iterator[KeyAction]:
        """The current task's scripted solution, one key action at a time, each computed from the
        true state after the previous one was executed (what the oracle policy plays)."""
        raise NotImplementedError(f"{type(self).__name__} has no scripted solutions")

    def set_frame_callback(self, callback: Callable[[], None] | None) -> bool:
        """Optional: call `callback()` after every frame stepped while executing actions
        (None removes it; a reset removes it too). Returns False when the simulator cannot: a
        rollout video then gets one picture per key action instead of one per frame."""
        return False

    @abstractmethod
    def demonstrate(self) -> Trajectory:
        """Run the task's scripted demonstrator from the current reset state and record it."""

    def close(self) -> None:
        """Release the scene and renderer."""


class Detector(ABC):
    """Finds named objects in an observation."""

    @abstractmethod
    def detect(self, obs: Observation, names: list[str]) -> dict[str, tuple[float, float, float]]:
        """World-frame centre of each name that was found; missing names are left out."""


class Encoder(ABC):
    """Turns a (first frame, instruction) pair into a feature vector for retrieval."""

    #: True when features depend on the frame: feature caches then hash the pool's frames too.
    uses_images: bool = False

    @abstractmethod
    def encode(self, items: list[tuple[np.ndarray | None, str]]) -> np.ndarray:
        """Features of shape (len(items), D), one row per (rgb, instruction) pair."""

    def cache_key(self) -> str:
        """A string that changes whenever the features would change (model, weights, config)."""
        return type(self).__name__


class Retriever(ABC):
    """Chooses the in-context demonstrations for a query from the pool."""

    def prepare(self, pool: list[Demo]) -> None:
        """Called once per run with the whole pool (compute and cache pool features here)."""

    def features_key(self) -> str:
        """What the ranking's features come from (a model and its weights' hash), for run.json:
        a resume whose key differs is refused. "" for a retriever with no learned features."""
        return ""

    @abstractmethod
    def select(self, query: Query, pool: list[Demo], k: int, rng: np.random.Generator) -> list[tuple[Demo, float]]:
        """k distinct demos with their scores, best first."""


class PromptBuilder(ABC):
    """Turns the chosen demos and the query into chat messages."""

    @abstractmethod
    def build(self, demos: list[Demo], query: Query, workspace: Box) -> Prompt:
        """The prompt for one LLM call; demos are given best first."""

    def scene_parts(self, task: str) -> list[str]:
        """Scene parts (segment names that are not among the task's objects) the prompt shows for
        `task`; the policy asks the detector for them too and passes them in Query.objects."""
        return []


class LLM(ABC):
    """Answers a prompt with text that should contain 7-integer key actions."""

    @abstractmethod
    def complete(self, prompt: Prompt) -> str:
        """The model's reply to the prompt."""

    @property
    @abstractmethod
    def deterministic(self) -> bool:
        """True when the same prompt always gets the same reply (greedy, or sampling seeded per
        call): only then does the response cache (llm_cache) answer for the model. A plugin
        declares it (a class attribute or a property)."""

    #: how many requests the model serves at once (an LLM server's slots, decoded in one batch);
    #: above 1, X-ICM's `envs=N` slots send their requests together (Policy.acts_concurrently)
    concurrent_requests: int = 1

    def identity(self) -> str:
        """Model and decoding settings; part of the response-cache key."""
        return type(self).__name__

    def check_ready(self) -> None:
        """Called once when a run starts, before any episode: raise ConfigError (one sentence)
        if the model cannot answer at all (e.g. its server is down or does not serve it)."""


class Policy(ABC):
    """Maps observations (with the instruction in them) to key actions, one episode at a time.

    The episode runner (xicm.core.execution.episode) resets the simulator, calls `reset`, then asks
    `act` for actions and executes them one by one until the task succeeds or the step budget
    is spent; when the actions run out it observes again and asks `act` once more. To give up,
    raise xicm.core.contracts.errors.EpisodeFailure(kind, message).
    """

    #: False for policies that read the simulator's true state (the oracle): the runner then
    #: skips rendering a new observation between calls of `act` and passes the first one again.
    observes: bool = True

    #: True when the instances built for the environments of an `envs=N` run may act at the same
    #: time, each from its environment's thread (X-ICM over an LLM server with several slots: their
    #: requests then reach the server together). False: one `act_batch` per round answers them all.
    acts_concurrently: bool = False

    def on_episode(self, task: str, seed: int, episode: int) -> None:
        """Called before `reset` with the episode's identity (a remote policy sends it to its server)."""

    def reset(self, task: str, obs: Observation, rng: np.random.Generator) -> None:
        """Start an episode of `task`; `rng` is the episode's own generator for random choices."""

    @abstractmethod
    def act(self, obs: Observation) -> list[KeyAction | JointAction | ControlStep]:
        """The next actions (at least one) for the current observation: key poses, joint targets,
        or per-step actions (one or a chunk)."""

    def act_batch(self, peers: list[Policy], observations: list[Observation]) -> list:
        """Act for several environments at once (xicm-eval envs=N): `peers[i]`, the instance of
        this policy built for environment i (self is peers[0]), acts on `observations[i]`.
        Returns, per environment, its actions or the exception its act raised. Default: one
        after the other; a policy that can batch (a served model) overrides it."""
        answers: list = []
        for peer, obs in zip(peers, observations):
            try:
                answers.append(peer.act(obs))
            except Exception as exc:  # noqa: BLE001 - that environment's episode records it
                answers.append(exc)
        return answers

    def run_metadata(self) -> dict:
        """Facts about the whole run for run.json (e.g. X-ICM: its pool and pool size); JSON-serialisable."""
        return {}

    def record(self) -> dict:
        """Facts about the episode so far for episodes.jsonl: any of `retrieved`, `prompt_hash`,
        `responses`, `timings` (seconds per stage) and `extra` (anything JSON-serialisable);
        `transcript` (a list of {"messages", "reply"} per LLM call) goes to its own file instead."""
        return {}


@dataclass
class PolicyContext:
    """What a policy factory may build from: the run's config (all groups), the plugin
    registry (to create other plugins by name) and the run's live simulator."""

    cfg: Any
    registry: Any
    simulator: Simulator
