"""Decoding under the action grammar (llguidance matchers of `xicm.plugins.llms.action_grammar`).

`grammar_greedy_decode` is the fast path's greedy loop with the grammar: tokens the grammar
forces (brackets, ", ", "[" after "], ") are appended without asking the model and fed to it
together with the next step's tokens, so several go through in one forward pass; guessed draft
tokens (`fast_decode.lookup_draft`) are cut to their grammar-valid prefix and checked as in
`fast_decode.greedy_decode`; every chosen token is the argmax of the model's logits over the
tokens the grammar allows at that position, i.e. what grammar-constrained greedy ``generate``
picks. With ``reduced=True`` the output layer (lm_head; Gemma 3's has 262,144 rows) is evaluated
only on those allowed tokens (at most a few dozen digit and bracket tokens) instead of on the
whole vocabulary: the scores of the allowed tokens are the same dot products, so the choice is
the same (the final logit soft-cap, if any, is monotonic and does not change an argmax).

`ActionGrammarProcessor` is the same constraint as a transformers LogitsProcessor (one matcher
per batch row), for ``generate``: sampling, ``fast: false`` and `complete_batch`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from xicm.plugins.llms.action_grammar import allowed_tokens
from xicm.plugins.llms.fast_decode import lookup_draft, next_guess
from xicm.plugins.llms.prefix_cache import run_model


def reduced_head_supported(model) -> bool:
    """Whether the model is a body (``base_model``) followed by a linear output layer."""
    import torch

    head = model.get_output_embeddings() if hasattr(model, "get_output_embeddings") else None
    body = getattr(model, "base_model", None)
    return isinstance(head, torch.nn.Linear) and body is not None and body is not model


def _choices(model, feed, cache, allowed: list, reduced: bool) -> list[int]:
    """The model's choice at each of the last len(allowed) fed positions among allowed[j]
    (None: nothing to choose there)."""
    import torch

    keep = len(allowed)
    wanted = [a for a in allowed if a is not None]
    if reduced:
        hidden = model.base_model(input_ids=feed, past_key_values=cache, use_cache=True).last_hidden_state[0, -keep:]
        union = np.unique(np.concatenate(wanted)) if wanted else np.zeros(0, dtype=np.int64)
        head = model.get_output_embeddings()
        rows = torch.as_tensor(union, device=hidden.device)
        bias = None if head.bias is None else head.bias[rows]
        scores = torch.nn.functional.linear(hidden, head.weight[rows], bias).float().cpu().numpy()
        column = {int(t): i for i, t in enumerate(union)}
        picks = []
        for j, ids in enumerate(allowed):
            if ids is None:
                picks.append(None)
                continue
            cols = [column[int(t)] for t in ids]
            picks.append(int(ids[int(np.argmax(scores[j, cols]))]))
        return picks
    logits = run_model(model, feed, cache, keep=keep)[0].float()
    picks = []
    for j, ids in enumerate(allowed):
        if ids is None:
            picks.append(None)
            continue
        row = logits[j, torch.as_tensor(ids, device=logits.device)]
        picks.append(int(ids[int(row.argmax())]))
    return picks


def grammar_greedy_decode(
    model,
    cache,
    prompt_ids: Sequence[int],
    max_new_tokens: int,
    matcher,
    vocab_size: int,
    draft_tokens: int = 16,
    reduced: bool = True,
    ends: Callable[[list[int]], bool] | None = None,
) -> list[int]:
    """New token ids after prompt_ids: greedy decoding restricted to what the matcher allows,
    until the grammar is complete, max_new_tokens, or ends(tokens so far) is true (checked before
    each step; the caller cuts the text). cache holds prompt_ids[:-1]."""
    import torch

    device = next(model.parameters()).device
    context = np.asarray(prompt_ids, dtype=np.int64)
    out: list[int] = []
    pending = [int(prompt_ids[-1])]  # tokens not yet in the cache
    guess = max(0, int(draft_tokens))
    with torch.inference_mode():
        while len(out) < max_new_tokens and not matcher.is_stopped() and not (ends is not None and ends(out)):
            forced = list(matcher.compute_ff_tokens())[: max_new_tokens - len(out)]
            if forced:
                if not matcher.consume_tokens(forced):
                    raise RuntimeError(f"llguidance refused its own forced tokens: {matcher.get_error()}")
                out += forced
                pending += forced
                context = np.concatenate([context, np.asarray(forced, dtype=np.int64)])
                continue
            draft = lookup_draft(context, min(guess, max_new_tokens - len(out) - 1)) if guess else []
            draft = draft[: matcher.validate_tokens(draft)] if draft else []
            allowed = []
            for j, token in enumerate([None, *draft]):
                if token is not None:
                    matcher.consume_token(token)
                allowed.append(None if matcher.is_stopped() else allowed_tokens(matcher, vocab_size))
            if draft:
                matcher.rollback(len(draft))
            feed = torch.tensor([[*pending, *draft]], dtype=torch.long, device=device)
            chosen = _choices(model, feed, cache, allowed, reduced)
            accepted = 0
            while accepted < len(draft) and draft[accepted] == chosen[accepted]:
                accepted += 1
            cache.crop(accepted - len(draft))
            new = [*draft[:accepted]] + ([chosen[accepted]] if chosen[accepted] is not None else [])
            if not matcher.consume_tokens(new):
                raise RuntimeError(f"llguidance refused an allowed token: {matcher.get_error()}")
            out += new
            context = np.concatenate([context, np.asarray(new, dtype=np.int64)])
            # the last chosen token is not in the cache yet (a fully accepted stopping draft has none)
            pending = [new[-1]] if chosen[accepted] is not None else []
            if guess:
                guess = next_guess(guess, accepted, len(draft), int(draft_tokens))
    return out


def action_grammar_processor(factory, batch_size: int):
    """A transformers LogitsProcessor that masks each row's scores to its grammar's allowed tokens."""
    import llguidance.torch as llg_torch
    from transformers import LogitsProcessor

    class ActionGrammarProcessor(LogitsProcessor):
        def __init__(self) -> None:
            self.matchers = None

        def __call__(self, input_ids, scores):
            if self.matchers is None:  # first step: nothing generated yet
                self.matchers = [factory.new() for _ in range(batch_size)]
            else:
                for row, matcher in enumerate(self.matchers):
                    if not matcher.is_stopped():
                        matcher.consume_token(int(input_ids[row, -1]))
            mask = llg_torch.allocate_token_bitmask(batch_size, factory.vocab_size)
            for row, matcher in enumerate(self.matchers):
                llg_torch.fill_next_token_bitmask(matcher, mask, row)
            llg_torch.apply_token_bitmask_inplace(scores, mask.to(scores.device))
            return scores

    return ActionGrammarProcessor()
