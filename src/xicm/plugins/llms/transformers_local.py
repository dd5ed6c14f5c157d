"""`transformers_local`: a causal LM run in-process with Hugging Face transformers, offline.

Every option is documented in `xicm.plugins.llms.transformers_local_options` (the user's
reference). The LLM holds one part per job, each built with what it reads: `loaded`
(local_model.LoadedModel: which files the ``model`` option names, loading them), `prompts`
(local_prompt.PromptEncoder: chat messages -> prompt ids that fit) and `generator`
(local_generation.Generator: plain ``generate`` and the fast path); this module checks the
options, turns them into the parts' settings, and keeps the replies and identity().
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

from xicm.core.contracts.errors import ConfigError
from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.interfaces import LLM
from xicm.core.contracts.types import Prompt
from xicm.plugins.llms import model_files, stopping
from xicm.plugins.llms.action_grammar import check_grammar
from xicm.plugins.llms.local_generation import Generator
from xicm.plugins.llms.local_model import LoadedModel
from xicm.plugins.llms.local_prompt import PromptEncoder
from xicm.plugins.llms.transformers_local_options import CHAT_TEMPLATE_MODES, TransformersLocalOptions


class TransformersLocalLLM(LLM):
    """A causal LM loaded with transformers in this process (lazily, on first use)."""

    #: the same prompt always gets the same reply: greedy, or sampling seeded before every call
    deterministic = True

    def __init__(self, options: TransformersLocalOptions | None = None):
        o = options if options is not None else TransformersLocalOptions()
        if o.chat_template not in CHAT_TEMPLATE_MODES and not ("{{" in o.chat_template or "{%" in o.chat_template):
            raise ConfigError(
                f"llm.chat_template '{o.chat_template}' is neither a Jinja template nor one of: "
                f"{', '.join(CHAT_TEMPLATE_MODES)}"
            )
        stop = [o.stop] if isinstance(o.stop, str) and o.stop != "auto" else o.stop
        if stop is not None and stop != "auto" and not (isinstance(stop, list) and all(isinstance(x, str) and x for x in stop)):
            raise ConfigError(f"llm.stop must be 'auto', null or a list of non-empty strings, got {stop!r}")
        grammar = check_grammar(str(o.grammar))
        if o.on_repeated_action not in stopping.REPEAT_MODES:
            raise ConfigError(
                f"llm.on_repeated_action '{o.on_repeated_action}' is not one of: {', '.join(stopping.REPEAT_MODES)}"
            )
        fill_applies = grammar != "none" and not o.do_sample
        repeat = o.on_repeated_action if o.on_repeated_action != "fill" or fill_applies else "decode"
        self.options = o
        self.loaded = LoadedModel(o.model, o.cache_dir, o.dtype, o.device, o.torch_threads, o.trust_remote_code,
                                  o.chat_template)
        self.prompts = PromptEncoder(self.loaded, o.chat_template, stop, o.max_prompt_tokens, o.max_new_tokens,
                                     o.prompt_overflow)
        self.generator = Generator(  # the speed options apply only on the fast path (fast: true)
            self.loaded, self.prompts, max_new_tokens=o.max_new_tokens, do_sample=o.do_sample,
            temperature=o.temperature, top_p=o.top_p, repetition_penalty=o.repetition_penalty, seed=o.seed,
            fast=o.fast, stop_at_action_list=o.fast and o.stop_at_action_list,
            on_repeated_action=repeat if o.fast else "decode", use_prefix_cache=o.fast and o.prefix_cache,
            draft_tokens=o.draft_tokens if o.fast else 0, grammar=grammar, reduced_output_layer=o.reduced_output_layer,
        )

    def load(self) -> None:
        """Load tokenizer and weights now (otherwise the first reply does)."""
        self.loaded.load()

    @property
    def grammar(self) -> str:
        """The reply's grammar, as every built-in LLM names it (none | actions)."""
        return self.generator.grammar

    @property
    def last_call(self) -> dict[str, float]:
        """Fast path: reused_tokens, prefill_s, decode_s, new_tokens of the last reply (as llamacpp's)."""
        return self.generator.last_call

    def complete(self, prompt: Prompt) -> str:
        self._check_form(prompt)
        return self.complete_messages(prompt.messages)

    def _check_form(self, prompt: Prompt) -> None:
        # its grammar (llguidance matchers built once per tokenizer) knows absolute actions only
        if prompt.anchors is not None and self.grammar != "none":
            raise ConfigError("llm=transformers_local constrains replies to absolute actions only: with "
                              "prompt.actions=anchored set llm.grammar=none or use the llamacpp engine")

    def complete_messages(self, messages: list[dict[str, str]]) -> str:
        """Reply to raw chat messages (complete() without a Prompt object)."""
        ids = self.prompts.fit(self.prompts.encode(messages))
        return self.reply(self.generator.generate_ids(ids))

    def complete_batch(self, prompts: list[Prompt]) -> list[str]:
        """Replies to several prompts from one left-padded generate call (no prefix cache; greedy
        replies equal complete()'s up to rounding, sampled ones differ)."""
        from xicm.plugins.llms.batch_generate import generate_batch

        self.load()
        for prompt in prompts:
            self._check_form(prompt)
        id_lists = [self.prompts.fit(self.prompts.encode(p.messages)) for p in prompts]
        generator = self.generator
        if generator.do_sample:
            import torch

            torch.manual_seed(generator.seed)
        rows = generate_batch(
            self.loaded.model, id_lists, self.loaded.pad_id(), self.loaded.decode, generator.rules,
            {**generator.generation_kwargs(), **generator.grammar_kwargs(len(id_lists))},
        )
        return [self.reply(row) for row in rows]

    def reply(self, new_ids: list[int]) -> str:
        """The reply text of the new token ids: cut at the first stop string, the repeated action
        cut or filled (on_repeated_action), cut after the action list (stop_at_action_list)."""
        return self.generator.rules.reply(self.loaded.decode, new_ids)

    def cut_at_stop(self, text: str) -> str:
        """Text up to the first stop string (a reply that starts with one keeps its first line)."""
        return stopping.cut_at_stop(text, self.prompts.stop_strings)

    def identity(self) -> str:
        o, g = self.options, self.generator
        settings: dict[str, Any] = {
            "llm": "transformers_local",
            "model": self.loaded.label,
            "chat_template": o.chat_template
            if o.chat_template in CHAT_TEMPLATE_MODES
            else "custom:" + hashlib.sha256(o.chat_template.encode()).hexdigest()[:12],
            "stop": self.prompts.stop_option,
            "dtype": o.dtype,
            "max_new_tokens": o.max_new_tokens,
            "max_prompt_tokens": o.max_prompt_tokens,
            "prompt_overflow": o.prompt_overflow,
            "do_sample": o.do_sample,
        }
        if g.grammar != "none":
            settings["grammar"] = g.grammar
        if g.stop_at_action_list:  # speed options that can change a reply (they cut it)
            settings["stop_at_action_list"] = True
        if g.on_repeated_action != "decode":
            settings["on_repeated_action"] = g.on_repeated_action
        if o.do_sample:
            settings.update(
                temperature=float(o.temperature), top_p=float(o.top_p), repetition_penalty=float(o.repetition_penalty),
                seed=o.seed,
            )
        return json.dumps(settings, sort_keys=True)


@hookimpl
def register_llms(register):
    register("transformers_local", TransformersLocalLLM, options=TransformersLocalOptions)


if __name__ == "__main__":  # print the converted embedded model folder, converting it if needed
    print(model_files.embedded_model_dir())
