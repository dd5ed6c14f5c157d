"""X-ICM for one episode: detect -> retrieve -> prompt -> LLM -> parse -> act, re-asking the
LLM with the current observation when its actions run out. Never raises for a bad episode."""

from __future__ import annotations

import hashlib
import json
import time
import traceback
from contextlib import contextmanager
from dataclasses import dataclass, field

from xicm.core import parsing
from xicm.core.errors import LLMError
from xicm.core.interfaces import LLM, Detector, PromptBuilder, Retriever, Simulator
from xicm.core.seeding import episode_rng
from xicm.core.types import Demo, EpisodeResult, Observation, Query


class EpisodeFailure(Exception):
    """Ends an episode as a failure of a given kind (caught inside run_episode)."""

    def __init__(self, kind: str, message: str):
        super().__init__(message)
        self.kind = kind
        self.message = message


@dataclass
class XICMAgent:
    simulator: Simulator
    detector: Detector
    retriever: Retriever
    prompt_builder: PromptBuilder
    llm: LLM
    pool: list[Demo]
    k: int = 18
    max_steps: int = 25
    max_llm_calls: int | None = None
    _timings: dict[str, float] = field(default_factory=dict, repr=False)

    def run_episode(self, task: str, seed: int, episode: int) -> EpisodeResult:
        result = EpisodeResult(task=task, seed=seed, episode=episode, success=False, steps=0)
        self._timings = {}
        start = time.perf_counter()
        try:
            self._run(result)
        except EpisodeFailure as failure:
            result.error_kind, result.error_message = failure.kind, failure.message
        except Exception as exc:  # a bug in a plugin or in our code: record it, keep the run going
            result.error_kind = "internal_error"
            result.error_message = f"{type(exc).__name__}: {exc} | {_last_frame(exc)}"
        result.timings = {k: round(v, 4) for k, v in self._timings.items()}
        result.timings["total"] = round(time.perf_counter() - start, 4)
        return result

    # ------------------------------------------------------------------ the loop
    def _run(self, result: EpisodeResult) -> None:
        with self._stage("reset", "sim_error"):
            obs = self.simulator.reset(result.task, result.seed, result.episode)
        rng = episode_rng(result.seed, result.task, result.episode, stream="retrieval")
        demos: list[Demo] | None = None
        llm_calls = 0
        while result.steps < self.max_steps:
            if self.max_llm_calls is not None and llm_calls >= self.max_llm_calls:
                raise EpisodeFailure("max_llm_calls", f"no success after {llm_calls} LLM calls")
            query = self._query(result.task, obs)
            if demos is None:  # demos are chosen once, from the first observation
                with self._stage("retrieve", "retrieval_error"):
                    chosen = self.retriever.select(query, self.pool, self.k, rng)
                demos = [d for d, _ in chosen]
                result.retrieved = [d.demo_id for d in demos]
            with self._stage("prompt", "internal_error"):
                prompt = self.prompt_builder.build(demos, query, self.simulator.workspace)
            if result.prompt_hash is None:
                result.prompt_hash = prompt_hash(prompt.messages)
            with self._stage("llm", "llm_error"):
                reply = self.llm.complete(prompt)
            llm_calls += 1
            result.responses.append(reply)
            with self._stage("parse", "parse_error"):
                actions = parsing.parse_actions(reply, self.simulator.workspace)
            if isinstance(actions, parsing.ParseError):
                raise EpisodeFailure(actions.kind, actions.reason)
            for action in actions:
                if result.steps >= self.max_steps:
                    break
                with self._stage("execute", "sim_error"):
                    outcome = self.simulator.execute(action)
                result.steps += 1
                if not outcome.ok:
                    raise EpisodeFailure(outcome.error_kind or "sim_error", outcome.error_message or "step failed")
                if outcome.success:
                    result.success = True
                    return
            with self._stage("observe", "sim_error"):
                obs = self.simulator.observe()
        raise EpisodeFailure("max_steps", f"no success within {self.max_steps} key actions")

    def _query(self, task: str, obs: Observation) -> Query:
        with self._stage("detect", "detector_error"):
            objects = self.detector.detect(obs, list(obs.object_names))
        front = obs.cameras.get("front")
        return Query(task=task, instruction=obs.instruction, objects=objects, front_rgb=None if front is None else front.rgb)

    @contextmanager
    def _stage(self, name: str, error_kind: str):
        """Time a stage; turn its exceptions into an EpisodeFailure of the stage's kind."""
        t0 = time.perf_counter()
        try:
            yield
        except EpisodeFailure:
            raise
        except LLMError as exc:
            raise EpisodeFailure(exc.kind, str(exc)) from exc
        except Exception as exc:
            raise EpisodeFailure(error_kind, f"{name} failed: {type(exc).__name__}: {exc} | {_last_frame(exc)}") from exc
        finally:
            self._timings[name] = self._timings.get(name, 0.0) + time.perf_counter() - t0


def prompt_hash(messages: list[dict[str, str]]) -> str:
    """Short stable hash of the chat messages (to compare prompts across runs)."""
    blob = json.dumps(messages, sort_keys=True, ensure_ascii=False).encode()
    return hashlib.sha256(blob).hexdigest()[:16]


def _last_frame(exc: BaseException) -> str:
    frames = traceback.extract_tb(exc.__traceback__)
    if not frames:
        return ""
    f = frames[-1]
    return f"{f.filename.rsplit('/', 1)[-1]}:{f.lineno}"
