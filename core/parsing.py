"""LLM reply text -> key actions, or a ParseError that says why not. Never raises on any text."""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass

from xicm.core import encoding
from xicm.core.types import KeyAction

MAX_ACTIONS = 26  # upstream keeps at most 26 actions from one reply
#: X-ICM's fallback action (its agent's default when a reply cannot be read): near the start pose, gripper open
XICM_DEFAULT_ACTION = (57, 49, 87, 0, 39, 0, 1)
RANGES = "position 0-99, rotation 0-72, gripper 0/1"

# An innermost bracketed group: '[' then anything but brackets then ']'.
_INNERMOST = re.compile(r"\[([^\[\]]*)\]")
_INT = re.compile(r"^[+-]?\d+$")


@dataclass(frozen=True)
class ParseError:
    """Why a reply yielded no action (kind is always 'parse_error')."""

    reason: str
    kind: str = "parse_error"


def innermost_groups(text: str) -> Iterator[tuple[list[int] | None, int]]:
    """(its 7 integers, or None when it is not a group of exactly 7 integers; the index just past
    its ']') for every innermost [...] group of the text, in order."""
    for match in _INNERMOST.finditer(text or ""):
        parts = [p.strip() for p in match.group(1).split(",")]
        ints = [int(p) for p in parts] if len(parts) == 7 and all(_INT.match(p) for p in parts) else None
        yield ints, match.end()


def parse_action_ints(text: str, max_actions: int = MAX_ACTIONS) -> list[list[int]]:
    """Every innermost [...] group of exactly 7 integers, in order, at most max_actions."""
    found: list[list[int]] = []
    for ints, _ in innermost_groups(text):
        if ints is not None:
            found.append(ints)
            if len(found) >= max_actions:
                break
    return found


def parse_actions(
    text: object, workspace: encoding.Box, max_actions: int = MAX_ACTIONS, partial: bool = False
) -> list[KeyAction] | ParseError:
    """Key actions decoded from the reply, or a ParseError with the reason.

    By default one out-of-range group rejects the whole reply. With partial=True the groups before
    the first invalid one are kept (as X-ICM executes a reply's actions in order until one fails);
    an invalid one is a 7-item group that is out of range or not all integers. A reply with no valid
    group before that is still a ParseError. `partial_stop` tells why a partial reply was cut.
    """
    if not isinstance(text, str):
        return ParseError(f"the reply is {type(text).__name__}, not text")
    if not text.strip():
        return ParseError("the reply is empty")
    if partial:
        return _parse_prefix(text, workspace, max_actions)
    groups = parse_action_ints(text, max_actions)
    if not groups:
        return _no_group(text)
    out_of_range = [g for g in groups if not _in_range(g)]
    if out_of_range:
        return ParseError(f"action {out_of_range[0]} is out of range ({RANGES})")
    return [encoding.ints_to_action(g, workspace) for g in groups]


def parse_actions_xicm(text: object, workspace: encoding.Box) -> tuple[list[KeyAction], str | None]:
    """X-ICM's reading of a reply (its agent's re_match), and which fallback it took (None: none).

    Every innermost [...] group with a digit in it is read as comma-separated integers. If any
    item of any such group is not an integer, the whole reply becomes MAX_ACTIONS default actions;
    if no group has 7 items, one default action (the policy then asks the LLM again). Otherwise
    the 7-item groups, at most MAX_ACTIONS, with no range check: a position off the grid is
    refused when it is executed, as upstream's planner refuses it.
    """
    text = text if isinstance(text, str) else ""
    groups = [m.group(1) for m in _INNERMOST.finditer(text) if any(c.isdigit() for c in m.group(1))]
    default = encoding.ints_to_action(XICM_DEFAULT_ACTION, workspace)
    items = [[p.strip() for p in g.split(",")] for g in groups]
    bad = next((g for g in items if not all(_INT.match(p) for p in g)), None)
    if bad is not None:
        return [default] * MAX_ACTIONS, f"item of [{', '.join(bad)}] is not an integer: {MAX_ACTIONS} default actions"
    sevens = [[int(p) for p in g] for g in items if len(g) == 7][:MAX_ACTIONS]
    if not sevens:
        return [default], "no group of 7 integers: one default action"
    return [encoding.ints_to_action(g, workspace) for g in sevens], None


def partial_stop(text: str, max_actions: int = MAX_ACTIONS) -> str | None:
    """Why a partial parse stopped early (its first invalid 7-item group), or None if it did not."""
    return _valid_prefix(text, max_actions)[1]


def _parse_prefix(text: str, workspace: encoding.Box, max_actions: int) -> list[KeyAction] | ParseError:
    kept, stop = _valid_prefix(text, max_actions)
    if kept:
        return [encoding.ints_to_action(g, workspace) for g in kept]
    return ParseError(f"the first {stop}") if stop else _no_group(text)


def _valid_prefix(text: str, max_actions: int) -> tuple[list[list[int]], str | None]:
    """The 7-integer in-range groups before the first invalid 7-item group, and why it is invalid."""
    kept: list[list[int]] = []
    for parts in _seven_item_groups(text):
        if len(kept) >= max_actions:
            break
        if not all(_INT.match(p) for p in parts):
            return kept, f"action [{', '.join(parts)}] is not 7 integers"
        values = [int(p) for p in parts]
        if not _in_range(values):
            return kept, f"action {values} is out of range ({RANGES})"
        kept.append(values)
    return kept, None


def _seven_item_groups(text: str):
    """The items of every innermost [...] group that has exactly 7 comma-separated items, in order."""
    for match in _INNERMOST.finditer(text):
        parts = [p.strip() for p in match.group(1).split(",")]
        if len(parts) == 7:
            yield parts


def _no_group(text: str) -> ParseError:
    snippet = text.strip().replace("\n", " ")[:80]
    return ParseError(f"no [x, y, z, roll, pitch, yaw, gripper] group of 7 integers in the reply: {snippet!r}")


def _in_range(values: list[int]) -> bool:
    pos_ok = all(0 <= v < encoding.GRID for v in values[:3])
    # 72 is accepted: it wraps to bin 0 (rounding of +180 degrees).
    rot_ok = all(0 <= v <= encoding.ROT_BINS for v in values[3:6])
    return pos_ok and rot_ok and values[6] in (0, 1)
