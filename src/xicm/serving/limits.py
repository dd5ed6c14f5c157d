"""The serving limits' defaults and xicm-serve-lerobot's flags for them (standard library only:
the LeRobot server imports this inside the lerobot environment). xicm-serve-policy takes the same
limits from `serve.*` in src/xicm/conf/config.yaml, whose values tests/test_serve_limits.py holds equal to these."""

from __future__ import annotations

import argparse

MAX_SESSIONS = 8  # clients served at once
IDLE_TIMEOUT_S = 300.0  # a client silent this long between requests is disconnected


def _positive(kind):
    def parse(text: str):
        value = kind(text)
        if value <= 0:
            raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
        return value
    return parse


def add_limit_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--api-key-env", default=None, metavar="VAR",
                        help="the NAME of an environment variable holding the key clients must send (openpi-client's "
                             "'Authorization: Api-Key <key>'); /healthz needs none")
    parser.add_argument("--max-sessions", type=_positive(int), default=MAX_SESSIONS, help="clients served at once; one more is refused")
    parser.add_argument("--idle-timeout-s", type=_positive(float), default=IDLE_TIMEOUT_S,
                        help="disconnect a client silent this long between requests")


def limit_arguments(args: argparse.Namespace) -> tuple[str, ...]:
    """The parsed limits as command-line arguments again (for the server script)."""
    key = ("--api-key-env", args.api_key_env) if args.api_key_env else ()
    return (*key, "--max-sessions", str(args.max_sessions), "--idle-timeout-s", str(args.idle_timeout_s))
