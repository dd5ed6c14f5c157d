"""LLM reply text -> key actions, or a ParseError that says why not. Never raises on any text."""

from __future__ import annotations

import re
from dataclasses import dataclass

from xicm.core import encoding
from xicm.core.types import KeyAction

MAX_ACTIONS = 26  # upstream keeps at most 26 actions from one reply

# An innermost bracketed group: '[' then anything but brackets then ']'.
_INNERMOST = re.compile(r"\[([^\[\]]*)\]")
_INT = re.compile(r"^[+-]?\d+$")


@dataclass(frozen=True)
class ParseError:
    """Why a reply yielded no action (kind is always 'parse_error')."""

    reason: str
    kind: str = "parse_error"


def parse_action_ints(text: str, max_actions: int = MAX_ACTIONS) -> list[list[int]]:
    """Every innermost [...] group of exactly 7 integers, in order, at most max_actions."""
    found: list[list[int]] = []
    for match in _INNERMOST.finditer(text or ""):
        parts = [p.strip() for p in match.group(1).split(",")]
        if len(parts) == 7 and all(_INT.match(p) for p in parts):
            found.append([int(p) for p in parts])
            if len(found) >= max_actions:
                break
    return found


def parse_actions(text: object, workspace: encoding.Box, max_actions: int = MAX_ACTIONS) -> list[KeyAction] | ParseError:
    """Key actions decoded from the reply, or a ParseError with the reason."""
    if not isinstance(text, str):
        return ParseError(f"the reply is {type(text).__name__}, not text")
    if not text.strip():
        return ParseError("the reply is empty")
    groups = parse_action_ints(text, max_actions)
    if not groups:
        snippet = text.strip().replace("\n", " ")[:80]
        return ParseError(f"no [x, y, z, roll, pitch, yaw, gripper] group of 7 integers in the reply: {snippet!r}")
    out_of_range = [g for g in groups if not _in_range(g)]
    if out_of_range:
        return ParseError(f"action {out_of_range[0]} is out of range (position 0-99, rotation 0-72, gripper 0/1)")
    return [encoding.ints_to_action(g, workspace) for g in groups]


def _in_range(values: list[int]) -> bool:
    pos_ok = all(0 <= v < encoding.GRID for v in values[:3])
    # 72 is accepted: it wraps to bin 0 (rounding of +180 degrees).
    rot_ok = all(0 <= v <= encoding.ROT_BINS for v in values[3:6])
    return pos_ok and rot_ok and values[6] in (0, 1)
