"""Where a generated reply ends, and what text it leaves: `StopRules`.

Pure text functions (no torch, apart from `StopRules.criteria`): the decoding loops of
`transformers_local` ask the rules whether the decoded new text ends the reply after every
step, and `StopRules.reply` turns the new token ids into the returned text.

End of the action list: the reply's first top-level bracketed span that is nested (an outer
list holding lists) and holds at least one group of 7 integers, e.g. ``[[1, 2, 3, 4, 5, 6, 1],
[...]]``. A flat ``[1, 2, 3, 4, 5, 6, 1]`` does not end the reply (the model may be writing
several groups without an outer list), nor does a span without a 7-integer group.

Repeated action: a 7-integer group equal to the group before it. A small greedy model that has
written its plan keeps repeating its last action until the token limit. ``on_repeat`` says what
happens when a reply repeats one:

- ``decode``: nothing; the model writes the whole reply.
- ``cut``: decoding stops and the reply is cut before the repeat, its open brackets closed
  (`repeat_cut`). It executes fewer actions than the whole reply.
- ``fill``: decoding stops and the repeat is written on, copy after copy, as far as the whole
  greedy reply would have gone if the model kept repeating: until ``max_new_tokens`` (each copy
  costs the tokens the model spent on the repeat) or ``MAX_ACTIONS`` groups; then the brackets
  are closed (`repeat_fill`). It executes what the whole reply would, unless the model would
  have turned to another action after repeating one.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from xicm.core.text.parsing import MAX_ACTIONS, innermost_groups

REPEAT_MODES = ("decode", "cut", "fill")
Decode = Callable[[list[int]], str]


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
            if depth == 0 and deepest >= 2 and any(ints for ints, _ in innermost_groups(text[start : i + 1])):
                return i + 1
    return None


def first_list_only(text: str) -> str:
    """The text cut just after its first nested action list (the whole text if it has none): the
    reply `stop_at_action_list` leaves, for engines that return whole replies."""
    end = action_list_end(text)
    return text if end is None else text[:end]


def _repeat_spans(text: str) -> tuple[int, int, int] | None:
    """(groups up to and including the repeated one, index past it, index past its repeat), or None."""
    previous = None
    count = 0
    for ints, end in innermost_groups(text):
        if ints is None:
            previous = None
            continue
        if previous is not None and ints == previous[0]:
            return count, previous[1], end
        count += 1
        previous = (ints, end)
    return None


def repeated_action_end(text: str) -> int | None:
    """Index just past the group that the next group repeats exactly (where the reply is cut), or None."""
    spans = _repeat_spans(text)
    return None if spans is None else spans[1]


def _close(text: str) -> str:
    """The text with its open brackets closed."""
    depth = 0
    for char in text:
        depth += 1 if char == "[" else -1 if char == "]" and depth > 0 else 0
    return text + "]" * depth


def repeat_cut(text: str) -> str:
    """The text cut just after the group that is repeated next, with its open brackets closed."""
    end = repeated_action_end(text)
    return text if end is None else _close(text[:end])


def _tokens_for(decode: Decode, ids: Sequence[int], chars: int) -> int:
    """How many of ids decode to at least `chars` characters."""
    for n in range(len(ids) + 1):
        if len(decode(list(ids[:n]))) >= chars:
            return n
    return len(ids)


def repeat_fill(decode: Decode, ids: Sequence[int], text: str, budget: int, max_actions: int = MAX_ACTIONS) -> str:
    """The text (a prefix of decode(ids)) with its first repeated group written on until the
    token budget or max_actions groups, brackets closed; the text itself if nothing repeats."""
    spans = _repeat_spans(text)
    if spans is None:
        return text
    kept, end, repeat_end = spans
    first = _tokens_for(decode, ids, end)
    period = max(1, _tokens_for(decode, ids, repeat_end) - first)
    copies = min(max_actions - kept, max(0, budget - first) // period)
    return _close(text[:end] + text[end:repeat_end] * copies)


def stop_string_hit(text: str, stop_strings: Sequence[str]) -> bool:
    """Whether any stop string occurs in the text (generation stops as soon as one does)."""
    return any(s in text for s in stop_strings)


def cut_at_stop(text: str, stop_strings: Sequence[str]) -> str:
    """Text up to the first stop string; a stop string starting with a newline is not looked for at
    index 0, so a reply that starts with one keeps its first line."""
    cuts = [i for i in (text.find(s, 1 if s.startswith("\n") else 0) for s in stop_strings) if i >= 0]
    return text[: min(cuts)] if cuts else text


@dataclass(frozen=True)
class StopRules:
    """What ends a reply while it is decoded, and what text the reply leaves."""

    strings: tuple[str, ...] = ()
    action_list: bool = False  # end once the action list is closed
    on_repeat: str = "decode"  # one of REPEAT_MODES
    budget: int = 256  # max_new_tokens (what `fill` writes up to)

    @property
    def stops_at_repeat(self) -> bool:
        return self.on_repeat != "decode"

    def ends(self, text: str) -> bool:
        """Whether generation should stop after producing `text`."""
        return (
            stop_string_hit(text, self.strings)
            or (self.action_list and action_list_end(text) is not None)
            or (self.stops_at_repeat and repeated_action_end(text) is not None)
        )

    def repeat_ends(self, decode: Decode) -> Callable[[list[int]], bool] | None:
        """For the grammar loop: whether its tokens so far repeat an action (None when that does not stop it)."""
        if not self.stops_at_repeat:
            return None
        return lambda ids: repeated_action_end(decode(ids)) is not None

    def tokens_until_end(self, decode: Decode, ids: Sequence[int], start: int) -> int | None:
        """The smallest n > start with ends(decode(ids[:n])), or None: how many of `ids` a
        token-by-token loop would have produced before stopping (`start` tokens are known not to end it)."""
        for n in range(start + 1, len(ids) + 1):
            if self.ends(decode(list(ids[:n]))):
                return n
        return None

    def reply(self, decode: Decode, ids: Sequence[int]) -> str:
        """The reply from the new token ids: cut at the first stop string, then the repeat cut or
        filled, then cut just after the action list."""
        text = cut_at_stop(decode(list(ids)), self.strings)
        if self.on_repeat == "cut":
            text = repeat_cut(text)
        elif self.on_repeat == "fill":
            text = repeat_fill(decode, ids, text, self.budget)
        end = action_list_end(text) if self.action_list else None
        return text if end is None else text[:end]

    def criteria(self, decode: Decode, prompt_length: int):
        """A transformers StoppingCriteria that ends each row of a batch once its reply ends.

        `decode(ids)` turns new token ids into text; new tokens are those after `prompt_length`
        (the padded prompt length of the batch)."""
        import torch
        from transformers import StoppingCriteria

        rules = self

        class ReplyEnd(StoppingCriteria):
            def __call__(self, input_ids, scores, **kwargs):
                done = [rules.ends(decode(row[prompt_length:].tolist())) for row in input_ids]
                return torch.tensor(done, dtype=torch.bool, device=input_ids.device)

        return ReplyEnd()
