"""Turn a composed config into plugin instances, checking every name before anything heavy."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf

from xicm.core.errors import ConfigError
from xicm.core.plugins import Registry

# config group -> plugin family
GROUP_KINDS = {
    "simulator": "simulator",
    "detector": "detector",
    "encoder": "encoder",
    "retriever": "retriever",
    "prompt": "prompt",
    "llm": "llm",
    "policy": "policy",
}
# options that belong to the run, not to the plugin's factory
NON_FACTORY_KEYS = {"prompt": {"k"}}


def options(cfg: DictConfig, group: str) -> dict[str, Any]:
    """A group's options as a plain dict, without the keys the run itself uses."""
    data = OmegaConf.to_container(cfg[group], resolve=True)
    assert isinstance(data, dict)
    for key in NON_FACTORY_KEYS.get(group, ()):
        data.pop(key, None)
    return data


def check_names(cfg: DictConfig, registry: Registry, tasks: list[str]) -> None:
    """Raise UnknownPluginError / ConfigError naming what exists, before anything is built."""
    for group, kind in GROUP_KINDS.items():
        name = cfg[group].get("name")
        if name is None and group == "encoder":
            continue
        registry.get(kind, name)
    known = registry.names("task")
    unknown = [t for t in tasks if t not in known]
    if unknown:
        raise ConfigError(f"unknown task {', '.join(repr(t) for t in unknown)}; available: {', '.join(known)}")


def check_pool(path: str | Path) -> Path:
    path = Path(path)
    if not path.exists():
        raise ConfigError(
            f"no demonstration pool at {path}; run `xicm-collect benchmark=<name>` first "
            "(it writes pools/<benchmark.pool>.h5 under paths.data)"
        )
    return path


def build_encoder(cfg: DictConfig, registry: Registry):
    opts = options(cfg, "encoder")
    if opts.get("name") is None:
        return None
    return registry.create("encoder", opts)


def build_retriever(cfg: DictConfig, registry: Registry, encoder):
    return registry.create("retriever", options(cfg, "retriever"), encoder=encoder)


def build_llm(cfg: DictConfig, registry: Registry):
    """The configured LLM, behind the SQLite response cache when it decodes deterministically."""
    llm = registry.create("llm", options(cfg, "llm"))
    if cfg.llm_cache.enabled and getattr(llm, "deterministic", False):
        from xicm.core.llm_cache import CachedLLM

        llm = CachedLLM(llm, cfg.llm_cache.path)
    return llm
