"""Policy `xicm`: X-ICM built from the run's detector, encoder, retriever, prompt and LLM groups
over the demonstration pool of `benchmark.pool_tasks` (xicm.core.agent.XICMPolicy)."""

from __future__ import annotations

from xicm.core.hookspecs import hookimpl
from xicm.core.interfaces import PolicyContext


def create_xicm_policy(context: PolicyContext):
    from xicm.core import build
    from xicm.core.agent import XICMPolicy
    from xicm.core.dataset import load_pool
    from xicm.core.errors import ConfigError

    cfg, registry = context.cfg, context.registry
    pool_path = build.check_pool(cfg.pool_path)
    pool = load_pool(pool_path, tasks=list(cfg.benchmark.pool_tasks), with_images=True)
    if not pool:
        raise ConfigError(f"the pool {pool_path} holds no demos of {list(cfg.benchmark.pool_tasks)}; collect them first")
    encoder = build.build_encoder(cfg, registry)
    retriever = build.build_retriever(cfg, registry, encoder)
    retriever.prepare(pool)
    return XICMPolicy(
        detector=registry.create("detector", build.options(cfg, "detector")),
        retriever=retriever,
        prompt_builder=registry.create("prompt", build.options(cfg, "prompt")),
        llm=build.build_llm(cfg, registry),
        pool=pool,
        workspace=context.simulator.workspace,
        k=int(cfg.prompt.k),
        max_llm_calls=cfg.max_llm_calls,
    )


@hookimpl
def register_policies(register):
    register("xicm", create_xicm_policy)
