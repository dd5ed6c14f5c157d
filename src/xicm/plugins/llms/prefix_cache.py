"""Reuse of the key/value states of the prompt prefix shared with the previous call.

X-ICM prompts of one run share long prefixes: the system message always, and the K demos
within an episode (they are retrieved once; only the query line changes when the policy asks
again) and across the episodes of a task (the same instruction retrieves the same demos).

`PrefixCache.prepare(model, ids)` returns a transformers `DynamicCache` holding ``ids[:-1]``:
the states of the longest common token prefix with the previous call are copied from the
stored ones, only the rest is run through the model (its logits are not computed), and the
full states of ``ids[:-1]`` are stored for the next call. The caller then feeds ``ids[-1]``
(generation starts there), so the returned cache is never the stored one: decoding cannot
change what is stored.

Sliding-window layers (Gemma 3: 5 of every 6 layers attend to the last 512 tokens) keep only
their last ``window - 1`` states in a normal cache, which cannot be rolled back to an earlier
prefix. The stored copy is therefore built with past recording on (every state kept), and the
cache handed out holds the usual window, with past recording on so that a decoding loop can
roll back rejected draft tokens with ``crop``. Models whose cache has layers of any other kind
(linear attention, quantised, ...) are not supported: `supported` says so and the caller falls
back to a full prefill.
"""

from __future__ import annotations

from collections.abc import Sequence


def common_prefix_length(a: Sequence[int], b: Sequence[int]) -> int:
    """Length of the longest common prefix of two token lists."""
    n = min(len(a), len(b))
    i = 0
    while i < n and a[i] == b[i]:
        i += 1
    return i


def run_model(model, input_ids, cache, keep: int):
    """Logits of the last `keep` positions after feeding input_ids into cache (which grows)."""
    import inspect

    extra = {"logits_to_keep": keep} if "logits_to_keep" in inspect.signature(model.forward).parameters else {}
    logits = model(input_ids=input_ids, past_key_values=cache, use_cache=True, **extra).logits
    return logits[:, -keep:]


class PrefixCache:
    """The full key/value states of the previous prompt (minus its last token), per layer."""

    def __init__(self) -> None:
        self.ids: list[int] = []
        self._states: list[tuple] = []  # (keys, values) per layer, [1, heads, len(ids), head_dim]
        self.reused_tokens = 0  # prefix tokens taken from the store by the last prepare()
        self.computed_tokens = 0  # prompt tokens run through the model by the last prepare()

    def clear(self) -> None:
        self.ids, self._states = [], []

    @staticmethod
    def supported(model) -> bool:
        """Whether the model's DynamicCache has only full-attention and sliding-window layers."""
        from transformers import DynamicCache
        from transformers.cache_utils import DynamicLayer, DynamicSlidingWindowLayer

        try:
            layers = DynamicCache(config=model.config).layers
        except Exception:  # noqa: BLE001 - a config transformers cannot build a cache from: not supported
            return False
        return bool(layers) and all(type(layer) in (DynamicLayer, DynamicSlidingWindowLayer) for layer in layers)

    def prepare(self, model, ids: Sequence[int]):
        """A fresh DynamicCache holding the states of ids[:-1] (ids must have at least 2 tokens)."""
        import torch

        if len(ids) < 2:
            raise ValueError("a prompt needs at least 2 tokens to use the prefix cache")
        target = list(ids[:-1])
        reused = common_prefix_length(self.ids, target)
        recording = self._cache(model, reused)
        if reused < len(target):
            device = next(model.parameters()).device
            rest = torch.tensor([target[reused:]], dtype=torch.long, device=device)
            with torch.inference_mode():
                run_model(model, rest, recording, keep=1)
        self.ids = target
        self._states = [(layer.keys, layer.values) for layer in recording.layers]
        self.reused_tokens, self.computed_tokens = reused, len(target) - reused
        return self._cache(model, len(target), window_only=True)

    def _cache(self, model, length: int, window_only: bool = False):
        """A DynamicCache filled with the first `length` stored states and past recording on.

        window_only: sliding layers keep just their window (as after a normal prefill)."""
        from transformers import DynamicCache

        cache = DynamicCache(config=model.config)
        if not window_only:
            cache.activate_past_recording()
        if length:
            for layer, (keys, values) in zip(cache.layers, self._states):
                # update() concatenates into new tensors: the stored ones are only read
                layer.update(keys[:, :, :length], values[:, :, :length])
        if window_only:
            cache.activate_past_recording()
        return cache
