"""LLM reply text -> key actions, or a ParseError that says why not. Never raises on any text.

Replies are read in the form the prompt wrote its demos' actions in: 7 absolute integers per action,
or, when the prompt passes its query's anchors (`Prompt.anchors`, `prompt.actions: anchored`), 8
anchored ones (`xicm.core.text.encoding`, "anchored actions"), turned into the absolute 7 on reading.
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

from xicm.core.text import encoding
from xicm.core.contracts.types import KeyAction

MAX_ACTIONS = 26  # upstream keeps at most 26 actions from one reply
#: X-ICM's fallback action (its agent's default when a reply cannot be read): near the start pose, gripper open
XICM_DEFAULT_ACTION = (57, 49, 87, 0, 39, 0, 1)
RANGES = "position 0-99, rotation 0-72, gripper 0/1"
Anchors = Sequence[Sequence[float]] | None  # the query's objects in the prompt's order; None: absolute actions

# An innermost bracketed group: '[' then anything but brackets then ']'.
_INNERMOST = re.compile(r"\[([^\[\]]*)\]")
_INT = re.compile(r"^[+-]?\d+$")


@dataclass(frozen=True)
class ParseError:
    """Why a reply yielded no action (kind is always 'parse_error')."""

    reason: str
    kind: str = "parse_error"


def innermost_groups(text: str, size: int = 7) -> Iterator[tuple[list[int] | None, int]]:
    """(its `size` integers, or None when it is not a group of exactly `size` integers; the index
    just past its ']') for every innermost [...] group of the text, in order."""
    for match in _INNERMOST.finditer(text or ""):
        parts = [p.strip() for p in match.group(1).split(",")]
        ints = [int(p) for p in parts] if len(parts) == size and all(_INT.match(p) for p in parts) else None
        yield ints, match.end()


def parse_action_ints(text: str, max_actions: int = MAX_ACTIONS, size: int = 7) -> list[list[int]]:
    """Every innermost [...] group of exactly `size` integers, in order, at most max_actions."""
    found: list[list[int]] = []
    for ints, _ in innermost_groups(text, size):
        if ints is not None:
            found.append(ints)
            if len(found) >= max_actions:
                break
    return found


def parse_actions(
    text: object, workspace: encoding.Box, max_actions: int = MAX_ACTIONS, partial: bool = False, anchors: Anchors = None
) -> list[KeyAction] | ParseError:
    """Key actions decoded from the reply, or a ParseError with the reason.

    By default one out-of-range group rejects the whole reply. With partial=True the groups before
    the first invalid one are kept (as X-ICM executes a reply's actions in order until one fails);
    an invalid one is a 7-item group that is out of range or not all integers. A reply with no valid
    group before that is still a ParseError. `partial_stop` tells why a partial reply was cut.
    With `anchors` (the query's objects, metres, in the prompt's order) the groups are anchored
    actions of 8 integers, range-checked once resolved to the absolute 7.
    """
    if not isinstance(text, str):
        return ParseError(f"the reply is {type(text).__name__}, not text")
    if not text.strip():
        return ParseError("the reply is empty")
    if partial:
        return _parse_prefix(text, workspace, max_actions, anchors)
    groups = parse_action_ints(text, max_actions, _size(anchors))
    if not groups:
        return _no_group(text, anchors)
    absolute = [_absolute(g, anchors, workspace) for g in groups]
    for group, values in zip(groups, absolute):
        if values is None or not _in_range(values):
            return ParseError(_out_of_range(group, values))
    return [encoding.ints_to_action(values, workspace) for values in absolute]


def parse_actions_xicm(text: object, workspace: encoding.Box, anchors: Anchors = None) -> tuple[list[KeyAction], str | None]:
    """X-ICM's reading of a reply (its agent's re_match), and which fallback it took (None: none).

    Every innermost [...] group with a digit in it is read as comma-separated integers. If any
    item of any such group is not an integer, the whole reply becomes MAX_ACTIONS default actions;
    if no group has 7 items, one default action (the policy then asks the LLM again). Otherwise
    the 7-item groups, at most MAX_ACTIONS, with no range check: a position off the grid is
    refused when it is executed, as upstream's planner refuses it. With `anchors`, groups of 8
    (anchored actions) take the place of the 7-item ones, resolved on the anchors.
    """
    text = text if isinstance(text, str) else ""
    groups = [m.group(1) for m in _INNERMOST.finditer(text) if any(c.isdigit() for c in m.group(1))]
    default = encoding.ints_to_action(XICM_DEFAULT_ACTION, workspace)
    items = [[p.strip() for p in g.split(",")] for g in groups]
    bad = next((g for g in items if not all(_INT.match(p) for p in g)), None)
    if bad is not None:
        return [default] * MAX_ACTIONS, f"item of [{', '.join(bad)}] is not an integer: {MAX_ACTIONS} default actions"
    size = _size(anchors)
    groups = [[int(p) for p in g] for g in items if len(g) == size][:MAX_ACTIONS]
    if not groups:
        return [default], f"no group of {size} integers: one default action"
    absolute = [_absolute(g, anchors, workspace) for g in groups]
    if any(a is None for a in absolute):
        return [default], f"{_out_of_range(groups[absolute.index(None)], None)}: one default action"
    return [encoding.ints_to_action(a, workspace) for a in absolute], None


def partial_stop(
    text: str, max_actions: int = MAX_ACTIONS, anchors: Anchors = None, workspace: encoding.Box | None = None
) -> str | None:
    """Why a partial parse stopped early (its first invalid action-sized group), or None if it did
    not. Anchored replies (`anchors`) need the workspace to resolve their voxels."""
    return _valid_prefix(text, max_actions, anchors, workspace)[1]


def _parse_prefix(text: str, workspace: encoding.Box, max_actions: int, anchors: Anchors) -> list[KeyAction] | ParseError:
    kept, stop = _valid_prefix(text, max_actions, anchors, workspace)
    if kept:
        return [encoding.ints_to_action(g, workspace) for g in kept]
    return ParseError(f"the first {stop}") if stop else _no_group(text, anchors)


def _valid_prefix(text: str, max_actions: int, anchors: Anchors, workspace) -> tuple[list[list[int]], str | None]:
    """The in-range groups (as absolute 7 integers) before the first invalid action-sized group,
    and why it is invalid."""
    size = _size(anchors)
    kept: list[list[int]] = []
    for parts in _sized_groups(text, size):
        if len(kept) >= max_actions:
            break
        if not all(_INT.match(p) for p in parts):
            return kept, f"action [{', '.join(parts)}] is not {size} integers"
        values = [int(p) for p in parts]
        absolute = _absolute(values, anchors, workspace)
        if absolute is None or not _in_range(absolute):
            return kept, _out_of_range(values, absolute)
        kept.append(absolute)
    return kept, None


def _sized_groups(text: str, size: int):
    """The items of every innermost [...] group that has exactly `size` comma-separated items, in order."""
    for match in _INNERMOST.finditer(text):
        parts = [p.strip() for p in match.group(1).split(",")]
        if len(parts) == size:
            yield parts


def _size(anchors: Anchors) -> int:
    return 7 if anchors is None else encoding.ANCHORED_ITEMS


def _absolute(values: list[int], anchors: Anchors, workspace) -> list[int] | None:
    """The absolute 7 integers of a group (itself when not anchored); None for a negative object index."""
    if anchors is None:
        return values
    try:
        return encoding.anchored_to_absolute_ints(values, anchors, workspace)
    except ValueError:  # a negative object index (the group's size was checked by the caller)
        return None


def _out_of_range(values: list[int], absolute: list[int] | None) -> str:
    if absolute is None:
        return f"action {values} names object {values[0]}, and objects count from 0"
    if absolute is values:
        return f"action {values} is out of range ({RANGES})"
    return f"action {values} is out of range once anchored: {absolute} ({RANGES})"


def _no_group(text: str, anchors: Anchors = None) -> ParseError:
    snippet = text.strip().replace("\n", " ")[:80]
    form = "[x, y, z, roll, pitch, yaw, gripper] group of 7" if anchors is None else (
        "[object, dx, dy, dz, roll, pitch, yaw, gripper] group of 8")
    return ParseError(f"no {form} integers in the reply: {snippet!r}")


def _in_range(values: list[int]) -> bool:
    pos_ok = all(0 <= v < encoding.GRID for v in values[:3])
    # 72 is accepted: it wraps to bin 0 (rounding of +180 degrees).
    rot_ok = all(0 <= v <= encoding.ROT_BINS for v in values[3:6])
    return pos_ok and rot_ok and values[6] in (0, 1)
