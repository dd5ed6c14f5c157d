"""Keys for serving, read from the environment (never from a config value or a command line).

The header is openpi-client's: `Authorization: Api-Key <key>`
(openpi_client.websocket_client_policy sends it when given an api_key).
"""

from __future__ import annotations

import hmac
import ipaddress
import os

HEADER = "Authorization"
SCHEME = "Api-Key "


class KeyNotSet(ValueError):
    """A setting names an environment variable that is not set or is empty."""


def key_from_env(variable: str | None, setting: str) -> str | None:
    """The key held by environment variable `variable` (None: no key wanted); KeyNotSet (one
    sentence naming `setting`, never a value) if the variable is unset or empty."""
    if not variable:
        return None
    key = os.environ.get(str(variable), "")
    if not key.strip():
        raise KeyNotSet(f"{setting} names the environment variable {variable}, which is not set or is empty")
    return key


def header_value(key: str) -> str:
    return SCHEME + key


def key_matches(header: str | None, key: str) -> bool:
    """Whether an Authorization header carries `key`, compared in constant time."""
    return hmac.compare_digest((header or "").encode("utf-8", "surrogateescape"), header_value(key).encode("utf-8", "surrogateescape"))


def is_loopback(host: str) -> bool:
    """Whether a server bound to `host` is reachable from this machine only."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:  # a host name other than localhost: it may resolve to any address
        return False
