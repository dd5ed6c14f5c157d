"""Policy `xicm`, the method: X-ICM built from the run's detector, encoder, retriever, prompt and
LLM groups over a demonstration pool (options in src/xicm/conf/policy/xicm.yaml)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import List, Optional

from omegaconf import MISSING

from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.interfaces import PolicyContext
from xicm.core.text.encoding import KEYFRAME_RULES
from xicm.core.contracts.schema import at_least, one_of


@dataclass
class XicmPolicyOptions:
    k: int = field(default=MISSING, metadata=at_least(1))  # demonstrations in the prompt
    max_llm_calls: Optional[int] = field(default=MISSING, metadata=at_least(1))  # null: only max_steps limits
    pool: str = MISSING
    pool_tasks: List[str] = MISSING
    rerank: bool = False  # re-select the demos with the current observation on each LLM call (X-ICM does)
    partial_replies: bool = False  # run a reply's valid actions up to its first invalid one, then end (X-ICM does)
    #: read replies as X-ICM's agent does: an unreadable reply becomes its default actions, not a parse_error
    parse_fallback: bool = False
    #: the demos' key frames: ours (as stored in the pool) | xicm (re-derived from the stored
    #: trajectories with X-ICM's rule, whose stop test at frames 0-1 reads the trajectory's end)
    keyframes: str = field(default="ours", metadata=one_of(*KEYFRAME_RULES))


def create_xicm_policy(options: XicmPolicyOptions, context: PolicyContext):
    from . import parts
    from .policy import XICMPolicy

    o, cfg, registry = options, context.cfg, context.registry
    demos = parts.load_demos(o.pool, list(o.pool_tasks), o.keyframes)
    retriever = parts.build_retriever(cfg, registry, parts.build_encoder(cfg, registry))
    retriever.prepare(demos)
    return XICMPolicy(
        detector=registry.create("detector", parts.part_options(cfg, "detector")),
        retriever=retriever,
        prompt_builder=registry.create("prompt", parts.part_options(cfg, "prompt")),
        llm=parts.build_llm(cfg, registry),
        pool=demos,
        workspace=context.simulator.workspace,
        k=o.k,
        max_llm_calls=o.max_llm_calls,
        pool_path=o.pool,
        rerank=o.rerank,
        partial_replies=o.partial_replies,
        parse_fallback=o.parse_fallback,
    )


def check_xicm_config(cfg, registry) -> None:
    from . import parts

    parts.check_parts(cfg, registry, cfg.policy.pool)


@hookimpl
def register_policies(register):
    register("xicm", create_xicm_policy, options=XicmPolicyOptions, check=check_xicm_config)
