"""Option checking shared by the LLM plugin factories: unknown config keys fail with one sentence."""

from __future__ import annotations

import inspect
from typing import Any

from xicm.core.errors import ConfigError


def check_options(plugin: str, cls: type, options: dict[str, Any]) -> None:
    """Raise ConfigError naming the unknown options and the accepted ones."""
    params = inspect.signature(cls.__init__).parameters
    accepted = [p for p in params if p != "self" and params[p].kind is not inspect.Parameter.VAR_KEYWORD]
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        return
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        raise ConfigError(
            f"unknown option(s) {', '.join(unknown)} for llm '{plugin}'; available: {', '.join(accepted)}"
        )


def to_plain(value: Any) -> Any:
    """Mappings and sequences (e.g. OmegaConf DictConfig/ListConfig) as plain dicts and lists."""
    from collections.abc import Mapping, Sequence

    if isinstance(value, Mapping):
        return {str(k): to_plain(v) for k, v in value.items()}
    if isinstance(value, Sequence) and not isinstance(value, (str, bytes)):
        return [to_plain(v) for v in value]
    return value
