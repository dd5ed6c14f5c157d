"""Option values shared by the LLM plugins (each plugin's options schema sits beside it and is
checked by the registry before the LLM is built)."""

from __future__ import annotations

from typing import Any


def to_plain(value: Any) -> Any:
    """Mappings and sequences (e.g. OmegaConf DictConfig/ListConfig) as plain dicts and lists."""
    from collections.abc import Mapping, Sequence

    if isinstance(value, Mapping):
        return {str(k): to_plain(v) for k, v in value.items()}
    if isinstance(value, Sequence) and not isinstance(value, (str, bytes)):
        return [to_plain(v) for v in value]
    return value
