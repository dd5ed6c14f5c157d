"""Greedy decoding that checks several guessed tokens per forward pass (prompt lookup).

X-ICM replies copy much of their prompt (action lists look like the demos') and often repeat
themselves, so the tokens that follow are usually found earlier in the context. Each step
guesses up to ``draft_tokens`` tokens by finding the longest recent n-gram that ends the
context earlier in it (`lookup_draft`), runs the model once on the last token plus the guess,
and keeps the guessed tokens while they equal the model's own greedy choice, plus the model's
next token after them. The tokens are therefore the ones plain greedy decoding picks (up to
floating-point rounding of a multi-token pass, which can only matter for an exact tie), and
one forward pass reads the weights once for several tokens, which is what CPU decoding is
bound by. Rejected guesses are removed from the cache with ``crop``.

Only for greedy decoding without logits processors; `plain_greedy` says whether a generation
config is such.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from xicm.plugins.llms.prefix_cache import run_model

#: generation-config fields that would make plain `generate` change the logits before argmax
_PROCESSOR_FIELDS = {
    "repetition_penalty": (None, 1.0),
    "encoder_repetition_penalty": (None, 1.0),
    "no_repeat_ngram_size": (None, 0),
    "encoder_no_repeat_ngram_size": (None, 0),
    "bad_words_ids": (None,),
    "suppress_tokens": (None,),
    "begin_suppress_tokens": (None,),
    "forced_bos_token_id": (None,),
    "forced_eos_token_id": (None,),
    "sequence_bias": (None,),
    "min_length": (None, 0),
    "min_new_tokens": (None, 0),
    "exponential_decay_length_penalty": (None,),
    "num_beams": (None, 1),
}


def plain_greedy(generation_config, overrides: dict) -> bool:
    """Whether `generate(**overrides)` with this config is plain argmax decoding."""
    if overrides.get("do_sample", getattr(generation_config, "do_sample", False)):
        return False
    for name, neutral in _PROCESSOR_FIELDS.items():
        value = overrides.get(name, getattr(generation_config, name, None))
        if value not in neutral:
            return False
    return True


def lookup_draft(context: np.ndarray, max_tokens: int, max_ngram: int = 8) -> list[int]:
    """Up to max_tokens guessed next tokens: what followed the most recent earlier occurrence of
    the longest n-gram (max_ngram down to 1) that ends the context. A guess that runs into the
    end of the context continues periodically (a repeating pattern keeps repeating)."""
    n_ctx = len(context)
    if max_tokens < 1 or n_ctx < 2:
        return []
    for n in range(min(max_ngram, n_ctx - 1), 0, -1):
        suffix = context[n_ctx - n:]
        windows = np.lib.stride_tricks.sliding_window_view(context[: n_ctx - 1], n)
        hits = np.flatnonzero((windows == suffix).all(axis=1))
        if hits.size:
            start = int(hits[-1]) + n  # first token after the most recent earlier occurrence
            draft: list[int] = []
            for j in range(max_tokens):
                pos = start + j
                draft.append(int(context[pos]) if pos < n_ctx else draft[pos - n_ctx])
            return draft
    return []


def next_guess(guess: int, accepted: int, drafted: int, cap: int) -> int:
    """How many tokens to guess next: twice as many after a fully accepted guess (a reply that
    repeats itself is then checked in a few long passes), a little more than were accepted after
    a miss."""
    return min(cap, max(2, 2 * guess)) if accepted == drafted else max(2, accepted + 2)


def greedy_decode(
    model,
    cache,
    prompt_ids: Sequence[int],
    max_new_tokens: int,
    eos_token_ids: Sequence[int],
    ends: Callable[[list[int], int], int | None],
    draft_tokens: int = 16,
) -> list[int]:
    """New token ids after prompt_ids, as plain greedy `generate` would produce them.

    cache holds the states of prompt_ids[:-1] (past recording on). ends(tokens, checked) returns
    the number of tokens after which the reply ended (looking only past the first `checked`),
    or None; decoding stops there and the tokens are cut to it. An end-of-sequence token ends
    the reply too (it is kept, as generate keeps it).
    """
    import torch

    device = next(model.parameters()).device
    context = np.asarray(prompt_ids, dtype=np.int64)
    out: list[int] = []
    last = int(prompt_ids[-1])
    guess = max(0, int(draft_tokens))
    eos = {int(t) for t in eos_token_ids}
    with torch.inference_mode():
        while len(out) < max_new_tokens:
            draft = lookup_draft(context, min(guess, max_new_tokens - len(out) - 1)) if guess else []
            feed = torch.tensor([[last, *draft]], dtype=torch.long, device=device)
            chosen = run_model(model, feed, cache, keep=len(draft) + 1)[0].argmax(dim=-1).tolist()
            accepted = 0
            while accepted < len(draft) and draft[accepted] == chosen[accepted]:
                accepted += 1
            cache.crop(accepted - len(draft))  # drop rejected guesses (crop(0) trims sliding windows)
            new = chosen[: accepted + 1]
            checked = len(out)
            for token in new:
                out.append(token)
                if token in eos:
                    break
            if out[-1] in eos:
                end = ends(out[:-1], checked)
                return out[:end] if end is not None else out
            end = ends(out, checked)
            if end is not None:
                return out[:end]
            last = out[-1]
            context = np.concatenate([context, np.asarray(new, dtype=np.int64)])
            if guess:
                guess = next_guess(guess, accepted, len(draft), int(draft_tokens))
    return out
