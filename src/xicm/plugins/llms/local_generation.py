"""Decoding of `transformers_local`: plain ``generate`` (``fast: false``, the reference), the fast
path (prefix-cached prefill, then the draft-checking greedy loop, its grammar-constrained
variant, or ``generate`` when sampling), and the ``generate`` arguments that enforce the grammar.
Options: `xicm.plugins.llms.transformers_local_options`."""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

from xicm.plugins.llms import stopping
from xicm.plugins.llms.action_grammar import ActionMatcherFactory
from xicm.plugins.llms.local_model import LoadedModel
from xicm.plugins.llms.local_prompt import PromptEncoder
from xicm.plugins.llms.prefix_cache import PrefixCache


class Generator:
    """New token ids for the prompt ids of one `LoadedModel`: reads the loaded model, tokenizer and
    whether its cache can be reused, the stop strings of the `PromptEncoder`, the decoding options
    and the speed options in effect (the LLM turns the user's options into these: e.g. `fast:
    false` leaves no prefix cache, draft tokens or action-list stop); keeps the prefix cache, the
    grammar matchers and `last_call` (fast path: reused_tokens, prefill_s, decode_s, new_tokens)."""

    def __init__(self, loaded: LoadedModel, prompts: PromptEncoder, *, max_new_tokens: int, do_sample: bool,
                 temperature: float, top_p: float, repetition_penalty: float, seed: int, fast: bool,
                 stop_at_action_list: bool, on_repeated_action: str, use_prefix_cache: bool, draft_tokens: int,
                 grammar: str, reduced_output_layer: bool):
        self.loaded, self.prompts = loaded, prompts
        self.max_new_tokens, self.do_sample, self.seed = max_new_tokens, do_sample, seed
        self.temperature, self.top_p, self.repetition_penalty = temperature, top_p, repetition_penalty
        self.fast, self.stop_at_action_list, self.on_repeated_action = fast, stop_at_action_list, on_repeated_action
        self.use_prefix_cache, self.draft_tokens = use_prefix_cache, draft_tokens
        self.grammar, self.reduced_output_layer = grammar, reduced_output_layer
        self._matchers: ActionMatcherFactory | None = None  # built on first use (converts the tokenizer)
        self.prefix_cache = PrefixCache()
        self.last_call: dict[str, float] = {}

    def generation_kwargs(self) -> dict[str, Any]:
        kwargs: dict[str, Any] = {"max_new_tokens": self.max_new_tokens, "do_sample": self.do_sample}
        if self.do_sample:
            kwargs.update(
                temperature=self.temperature, top_p=self.top_p, top_k=None, repetition_penalty=self.repetition_penalty
            )
        else:  # override sampling defaults a model's generation_config may carry
            kwargs.update(temperature=None, top_p=None, top_k=None)
        return kwargs

    def generate_ids(self, ids: list[int]) -> list[int]:
        """New token ids for the prompt ids (the fast path unless ``fast: false``)."""
        self.loaded.load()
        if self.fast and len(ids) >= 2 and self.loaded.cache_supported:
            return self._generate_fast(ids)
        return self._generate_plain(ids)

    def _generate_plain(self, ids: list[int]) -> list[int]:
        import torch

        input_ids = torch.tensor([ids], dtype=torch.long, device=self.loaded.device)
        if self.do_sample:
            torch.manual_seed(self.seed)
        extra: dict[str, Any] = {}
        if self.prompts.stop_strings:
            extra = {"stop_strings": self.prompts.stop_strings, "tokenizer": self.loaded.tokenizer}
        if self.stop_at_action_list or self.rules.stops_at_repeat:  # the fast path on a model whose cache it cannot reuse
            from transformers import StoppingCriteriaList

            criteria = replace(self.rules, strings=()).criteria(self.loaded.decode, len(ids))
            extra["stopping_criteria"] = StoppingCriteriaList([criteria])
        extra.update(self.grammar_kwargs(1))
        with torch.inference_mode():
            out = self.loaded.model.generate(
                input_ids=input_ids,
                attention_mask=torch.ones_like(input_ids),
                pad_token_id=self.loaded.pad_id(),
                **self.generation_kwargs(),
                **extra,
            )
        return out[0, input_ids.shape[1]:].tolist()

    def _generate_fast(self, ids: list[int]) -> list[int]:
        """Prefix-cached prefill, then the draft-checking greedy loop (or generate when sampling)."""
        import torch
        from xicm.plugins.llms.fast_decode import greedy_decode, plain_greedy

        t0 = time.perf_counter()
        store = self.prefix_cache if self.use_prefix_cache else PrefixCache()
        cache = store.prepare(self.loaded.model, ids)
        self.last_call = {"reused_tokens": store.reused_tokens, "prefill_s": time.perf_counter() - t0}
        kwargs = self.generation_kwargs()
        greedy = plain_greedy(self.loaded.model.generation_config, kwargs)
        if greedy and self.grammar != "none":
            from xicm.plugins.llms.grammar_decode import grammar_greedy_decode, reduced_head_supported

            t0 = time.perf_counter()
            new_ids = grammar_greedy_decode(
                self.loaded.model, cache, ids, self.max_new_tokens, self.matchers().new(), self.loaded.vocab_size(),
                self.draft_tokens, self.reduced_output_layer and reduced_head_supported(self.loaded.model),
                ends=self.rules.repeat_ends(self.loaded.decode),
            )
            self.last_call.update(decode_s=time.perf_counter() - t0, new_tokens=len(new_ids))
            return new_ids
        if greedy:
            t0 = time.perf_counter()
            new_ids = greedy_decode(
                self.loaded.model, cache, ids, self.max_new_tokens, self.loaded.eos_ids(), self._tokens_until_end,
                self.draft_tokens,
            )
            self.last_call.update(decode_s=time.perf_counter() - t0, new_tokens=len(new_ids))
            return new_ids
        from transformers import StoppingCriteriaList

        input_ids = torch.tensor([ids], dtype=torch.long, device=self.loaded.device)
        criteria = self.rules.criteria(self.loaded.decode, len(ids))
        if self.do_sample:
            torch.manual_seed(self.seed)
        with torch.inference_mode():
            out = self.loaded.model.generate(
                input_ids=input_ids, attention_mask=torch.ones_like(input_ids), past_key_values=cache,
                pad_token_id=self.loaded.pad_id(), stopping_criteria=StoppingCriteriaList([criteria]), **kwargs,
                **self.grammar_kwargs(1),
            )
        return out[0, len(ids):].tolist()

    def matchers(self) -> ActionMatcherFactory:
        """The llguidance matcher factory of the action grammar for this model's tokenizer."""
        self.loaded.load()
        if self._matchers is None:
            self._matchers = ActionMatcherFactory(self.loaded.tokenizer, self.loaded.vocab_size(), self.loaded.eos_ids())
        return self._matchers

    def grammar_kwargs(self, batch_size: int) -> dict[str, Any]:
        """generate() arguments that enforce the grammar (none when it is off)."""
        if self.grammar == "none":
            return {}
        from transformers import LogitsProcessorList
        from xicm.plugins.llms.grammar_decode import action_grammar_processor

        return {"logits_processor": LogitsProcessorList([action_grammar_processor(self.matchers(), batch_size)])}

    def _tokens_until_end(self, new_ids: list[int], checked: int) -> int | None:
        return self.rules.tokens_until_end(self.loaded.decode, new_ids, checked)

    @property
    def rules(self) -> stopping.StopRules:
        """What ends a reply and what text it leaves (stop strings resolved once loaded)."""
        return stopping.StopRules(
            tuple(self.prompts.stop_strings), self.stop_at_action_list, self.on_repeated_action, self.max_new_tokens
        )
