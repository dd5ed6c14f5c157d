"""Keys come from environment variables, never from the config.

Every value of the composed config is written to run.json and the `.hydra/*.yaml` files and goes
to the wandb run (which `wandb sync` uploads), so a key there would leak. A setting names the
variable instead (`llm.api_key_env`, `policy.api_key_env`, `serve.api_key_env`); a key itself
given as a config value (`*.api_key`) is refused with one sentence that never repeats it, on the
command line before Hydra writes anything, and in config files before anything is built.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from xicm.core.contracts.errors import ConfigError

LITERAL_KEY_NAMES = ("api_key",)  # config keys that would hold a secret itself


def _refusal(key: str) -> ConfigError:
    parent = key.rsplit(".", 1)[0] + "." if "." in key else ""
    return ConfigError(
        f"{key} is refused: a key in the config is written to run.json, .hydra/ and the wandb run; "
        f"export it in an environment variable and set {parent}api_key_env to that variable's name"
    )


def refuse_literal_keys_on_command_line(args: Iterable[str]) -> None:
    """ConfigError for an override that sets `*.api_key` to anything but null (also with +, ++ or -m)."""
    for arg in args:
        if arg.startswith("-") or "=" not in arg:
            continue
        key, value = arg.split("=", 1)
        key = key.lstrip("+")
        if key.rsplit(".", 1)[-1] in LITERAL_KEY_NAMES and not key.startswith(("~", "hydra.")):
            if value.strip() not in ("", "null"):
                raise _refusal(key)


def refuse_literal_keys(config: Mapping[str, Any], prefix: str = "") -> None:
    """ConfigError for a non-null `*.api_key` anywhere in a config (a plain, unresolved container)."""
    for name, value in config.items():
        key = f"{prefix}{name}"
        if name in LITERAL_KEY_NAMES and value is not None:
            raise _refusal(key)
        if isinstance(value, Mapping):
            refuse_literal_keys(value, prefix=f"{key}.")
