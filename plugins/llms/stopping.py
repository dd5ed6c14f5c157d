"""Where a generated reply ends: the configured stop strings and the end of the action list.

Pure text functions (no torch): the decoding loops of `transformers_local` call them on the
decoded new text after every step, and cut the returned text with them.

End of the action list: the reply's first top-level bracketed span that is nested (an outer
list holding lists) and holds at least one group of 7 integers, e.g. ``[[1, 2, 3, 4, 5, 6, 1],
[...]]``. A flat ``[1, 2, 3, 4, 5, 6, 1]`` does not end the reply (the model may be writing
several groups without an outer list), nor does a span without a 7-integer group.

Repeated action (``repeat=True``): the reply ends once a 7-integer group equals the group before
it. A small greedy model that has written its plan keeps repeating its last action until the
token limit; executing an action equal to the previous one moves nothing, so the reply is cut
before the repeat and its open brackets are closed (`repeat_cut`).
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from xicm.core.parsing import parse_action_ints

_INNERMOST = re.compile(r"\[[^\[\]]*\]")


def action_list_end(text: str) -> int | None:
    """Index just past the bracket that closes the reply's first nested action list, or None."""
    depth = 0
    start = 0
    deepest = 0
    for i, char in enumerate(text):
        if char == "[":
            if depth == 0:
                start, deepest = i, 0
            depth += 1
            deepest = max(deepest, depth)
        elif char == "]" and depth > 0:
            depth -= 1
            if depth == 0 and deepest >= 2 and parse_action_ints(text[start : i + 1], max_actions=1):
                return i + 1
    return None


def repeated_action_end(text: str) -> int | None:
    """Index just past the group that the next group repeats exactly (where the reply is cut), or None."""
    previous = None
    for match in _INNERMOST.finditer(text):
        group = parse_action_ints(match.group(0), max_actions=1)
        if not group:
            previous = None
            continue
        if previous is not None and group[0] == previous[0]:
            return previous[1]
        previous = (group[0], match.end())
    return None


def repeat_cut(text: str) -> str:
    """The text cut just after the group that is repeated next, with its open brackets closed."""
    end = repeated_action_end(text)
    if end is None:
        return text
    depth = 0
    for char in text[:end]:
        depth += 1 if char == "[" else -1 if char == "]" and depth > 0 else 0
    return text[:end] + "]" * depth


def stop_string_hit(text: str, stop_strings: Sequence[str]) -> bool:
    """Whether any stop string occurs in the text (generation stops as soon as one does)."""
    return any(s in text for s in stop_strings)


def cut_at_stop(text: str, stop_strings: Sequence[str]) -> str:
    """Text up to the first stop string; a stop string starting with a newline is not looked for at
    index 0, so a reply that starts with one keeps its first line."""
    cuts = [i for i in (text.find(s, 1 if s.startswith("\n") else 0) for s in stop_strings) if i >= 0]
    return text[: min(cuts)] if cuts else text


def reply_ends(text: str, stop_strings: Sequence[str], action_list: bool, repeat: bool = False) -> bool:
    """Whether generation should stop after producing `text`."""
    return (
        stop_string_hit(text, stop_strings)
        or (action_list and action_list_end(text) is not None)
        or (repeat and repeated_action_end(text) is not None)
    )


def final_text(text: str, stop_strings: Sequence[str], action_list: bool, repeat: bool = False) -> str:
    """The reply: cut at the first stop string, then (if asked) before a repeated action, then
    just after the action list."""
    text = cut_at_stop(text, stop_strings)
    if repeat:
        text = repeat_cut(text)
    end = action_list_end(text) if action_list else None
    return text if end is None else text[:end]


def tokens_until_end(
    decode, ids: Sequence[int], start: int, stop_strings: Sequence[str], action_list: bool, repeat: bool = False
) -> int | None:
    """The smallest n > start with reply_ends(decode(ids[:n])), or None: how many of `ids` a
    token-by-token loop would have produced before stopping (`start` tokens are known not to end it)."""
    for n in range(start + 1, len(ids) + 1):
        if reply_ends(decode(ids[:n]), stop_strings, action_list, repeat):
            return n
    return None


def batch_stopping_criteria(
    decode, prompt_length: int, stop_strings: Sequence[str], action_list: bool, repeat: bool = False
):
    """A transformers StoppingCriteria that ends each row of a batch once its reply ends.

    `decode(ids)` turns new token ids into text; new tokens are those after `prompt_length`
    (the padded prompt length of the batch)."""
    import torch
    from transformers import StoppingCriteria

    class ReplyEnd(StoppingCriteria):
        def __call__(self, input_ids, scores, **kwargs):
            done = [
                reply_ends(decode(row[prompt_length:].tolist()), stop_strings, action_list, repeat) for row in input_ids
            ]
            return torch.tensor(done, dtype=torch.bool, device=input_ids.device)

    return ReplyEnd()
