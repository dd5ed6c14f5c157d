"""X-ICM as a policy: detect -> retrieve -> prompt -> LLM -> parse, re-asking the LLM with the
current observation whenever its actions have all been executed without success."""

from __future__ import annotations

import hashlib
import json
import time
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from xicm.core.text import parsing
from xicm.core.execution.episode import last_frame
from xicm.core.contracts.errors import EpisodeFailure, LLMError
from xicm.core.contracts.interfaces import LLM, Detector, Policy, PromptBuilder, Retriever
from xicm.core.contracts.types import Demo, KeyAction, Observation, Query


@dataclass
class XICMPolicy(Policy):
    detector: Detector
    retriever: Retriever
    prompt_builder: PromptBuilder
    llm: LLM
    pool: list[Demo]
    workspace: tuple
    k: int = 18
    max_llm_calls: int | None = None
    pool_path: str | None = None  # where the pool came from (for run.json)
    rerank: bool = False  # re-select demos on every LLM call, not only the first
    partial_replies: bool = False  # keep a reply's actions before its first invalid one
    parse_fallback: bool = False  # read replies as X-ICM does, with its default actions (parsing.parse_actions_xicm)

    def __post_init__(self) -> None:
        self._start("", np.random.default_rng(0))

    @property
    def acts_concurrently(self) -> bool:  # type: ignore[override]
        """An LLM that serves several requests at once gets the envs=N slots' requests together."""
        return int(getattr(self.llm, "concurrent_requests", 1)) > 1

    def reset(self, task: str, obs: Observation, rng: np.random.Generator) -> None:
        self._start(task, rng)

    def _start(self, task: str, rng: np.random.Generator) -> None:
        self.task, self.rng = task, rng
        self.demos: list[Demo] | None = None
        self.llm_calls = 0
        self._cut_reply: str | None = None  # why the last reply was cut short (partial_replies)
        self._record: dict = {"retrieved": [], "prompt_hash": None, "responses": [], "extra": {}}
        self._calls: list[dict] = []  # every prompt and reply: the episode's transcript file
        self._timings: dict[str, float] = {}

    def act(self, obs: Observation) -> list[KeyAction]:
        if self._cut_reply is not None:  # X-ICM's episode ends at the reply's first invalid action
            raise EpisodeFailure("parse_error", f"after the valid actions of reply {self.llm_calls}: {self._cut_reply}")
        if self.max_llm_calls is not None and self.llm_calls >= self.max_llm_calls:
            raise EpisodeFailure("max_llm_calls", f"no success after {self.llm_calls} LLM calls")
        with self._stage("detect", "detector_error"):
            scene_parts = getattr(self.prompt_builder, "scene_parts", None)  # optional (duck-typed builders)
            parts = [n for n in (scene_parts(self.task) if scene_parts else []) if n not in obs.object_names]
            objects = self.detector.detect(obs, list(obs.object_names) + parts)
        camera = obs.first_camera()  # the one the pool's pictures come from
        missing = tuple(n for n in obs.object_names if n not in objects)
        query = Query(self.task, obs.instruction, objects, None if camera is None else obs.cameras[camera].rgb, missing)
        if missing:
            seen = self._record["extra"].setdefault("not_detected", [])
            seen.extend(n for n in missing if n not in seen)
        if self.demos is None or self.rerank:  # by default chosen once, from the first observation
            with self._stage("retrieve", "retrieval_error"):
                chosen = self.retriever.select(query, self.pool, self.k, self.rng)
            self.demos = [d for d, _ in chosen]
            ids = [d.demo_id for d in self.demos]
            if not self._record["retrieved"]:
                self._record["retrieved"] = ids
            if self.rerank:
                self._record["extra"].setdefault("retrieved_per_call", []).append(ids)
        with self._stage("prompt", "internal_error"):
            prompt = self.prompt_builder.build(self.demos, query, self.workspace)
        if self._record["prompt_hash"] is None:
            self._record["prompt_hash"] = prompt_hash(prompt.messages)
        call = {"messages": prompt.messages, "reply": None}
        self._calls.append(call)
        with self._stage("llm", "llm_error"):
            reply = self.llm.complete(prompt)
        call["reply"] = reply
        self.llm_calls += 1
        self._record["responses"].append(reply)
        if self.parse_fallback:
            with self._stage("parse", "parse_error"):
                actions, fallback = parsing.parse_actions_xicm(reply, self.workspace, prompt.anchors)
            if fallback is not None:
                self._record["extra"].setdefault("parse_fallbacks", []).append(f"reply {self.llm_calls}: {fallback}")
            return actions
        with self._stage("parse", "parse_error"):
            actions = parsing.parse_actions(reply, self.workspace, partial=self.partial_replies, anchors=prompt.anchors)
        if isinstance(actions, parsing.ParseError):
            raise EpisodeFailure(actions.kind, actions.reason)
        if self.partial_replies:
            self._cut_reply = parsing.partial_stop(reply, anchors=prompt.anchors, workspace=self.workspace)
        return actions

    def run_metadata(self) -> dict:
        features = self.retriever.features_key()
        return {"pool": self.pool_path, "pool_size": len(self.pool), **({"retrieval_features": features} if features else {})}

    def record(self) -> dict:
        return {**self._record, "timings": dict(self._timings), "transcript": list(self._calls)}

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
            raise EpisodeFailure(error_kind, f"{name} failed: {type(exc).__name__}: {exc} | {last_frame(exc)}") from exc
        finally:
            self._timings[name] = self._timings.get(name, 0.0) + time.perf_counter() - t0


def prompt_hash(messages: list[dict[str, str]]) -> str:
    """Short stable hash of the chat messages (to compare prompts across runs)."""
    blob = json.dumps(messages, sort_keys=True, ensure_ascii=False).encode()
    return hashlib.sha256(blob).hexdigest()[:16]
