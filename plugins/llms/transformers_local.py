"""`transformers_local`: a causal LM run in-process with Hugging Face transformers, offline.

Every option is documented in `xicm.plugins.llms.transformers_local_options` (the user's
reference). The LLM is put together from one part per job: `local_model` (which files the
``model`` option names, loading them), `local_prompt` (chat messages -> prompt ids that fit) and
`local_generation` (plain ``generate`` and the fast path); this module keeps the options' checks,
the replies and identity().
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

from xicm.core.errors import ConfigError
from xicm.core.hookspecs import hookimpl
from xicm.core.interfaces import LLM
from xicm.core.types import Prompt
from xicm.plugins.llms import model_files, stopping
from xicm.plugins.llms.action_grammar import ActionMatcherFactory, check_grammar
from xicm.plugins.llms.local_generation import LocalGenerationMixin
from xicm.plugins.llms.local_model import LocalModelMixin, resolve_model
from xicm.plugins.llms.local_prompt import LocalPromptMixin
from xicm.plugins.llms.options import to_plain
from xicm.plugins.llms.prefix_cache import PrefixCache
from xicm.plugins.llms.transformers_local_options import CHAT_TEMPLATE_MODES, TransformersLocalOptions


class TransformersLocalLLM(LocalModelMixin, LocalPromptMixin, LocalGenerationMixin, LLM):
    """A causal LM loaded with transformers in this process (lazily, on first use)."""

    def __init__(
        self,
        model: str = model_files.EMBEDDED,
        cache_dir: str | None = None,
        max_new_tokens: int = 256,
        do_sample: bool = False,
        temperature: float = 0.1,
        top_p: float = 0.001,
        repetition_penalty: float = 1.05,
        seed: int = 0,
        max_prompt_tokens: int | None = None,
        prompt_overflow: str = "error",
        chat_template: str = "auto",
        stop: str | list[str] | None = "auto",
        dtype: str = "float32",
        device: str = "auto",
        torch_threads: int | None = None,
        trust_remote_code: bool = False,
        fast: bool = True,
        stop_at_action_list: bool = True,
        on_repeated_action: str = "decode",
        prefix_cache: bool = True,
        draft_tokens: int = 16,
        grammar: str = "actions",
        reduced_output_layer: bool = True,
    ):
        if chat_template not in CHAT_TEMPLATE_MODES and not ("{{" in chat_template or "{%" in chat_template):
            raise ConfigError(
                f"llm.chat_template '{chat_template}' is neither a Jinja template nor one of: "
                f"{', '.join(CHAT_TEMPLATE_MODES)}"
            )
        self.model_option = str(model)
        self.cache_dir = cache_dir
        self.max_new_tokens = int(max_new_tokens)
        self.do_sample = bool(do_sample)
        self.temperature = float(temperature)
        self.top_p = float(top_p)
        self.repetition_penalty = float(repetition_penalty)
        self.seed = int(seed)
        self.max_prompt_tokens = None if max_prompt_tokens is None else int(max_prompt_tokens)
        self.prompt_overflow = prompt_overflow
        self.chat_template = chat_template
        stop = to_plain(stop)
        if isinstance(stop, str) and stop != "auto":
            stop = [stop]
        if stop is not None and stop != "auto" and not all(isinstance(x, str) and x for x in stop):
            raise ConfigError(f"llm.stop must be 'auto', null or a list of non-empty strings, got {stop!r}")
        self.stop_option = stop if stop in (None, "auto") else [str(x) for x in stop]
        self.dtype_name = str(dtype)
        self.device_option = str(device)
        self.torch_threads = None if torch_threads is None else int(torch_threads)
        self.trust_remote_code = bool(trust_remote_code)
        self.fast = bool(fast)
        self.stop_at_action_list = self.fast and bool(stop_at_action_list)
        self.grammar = check_grammar(str(grammar))
        if on_repeated_action not in stopping.REPEAT_MODES:
            raise ConfigError(
                f"llm.on_repeated_action '{on_repeated_action}' is not one of: {', '.join(stopping.REPEAT_MODES)}"
            )
        fill_applies = self.grammar != "none" and not self.do_sample
        keep = on_repeated_action if on_repeated_action != "fill" or fill_applies else "decode"
        self.on_repeated_action = keep if self.fast else "decode"
        self.use_prefix_cache = self.fast and bool(prefix_cache)
        self.draft_tokens = int(draft_tokens) if self.fast else 0
        self.reduced_output_layer = bool(reduced_output_layer)
        self._matchers: ActionMatcherFactory | None = None  # built on first use (converts the tokenizer)
        self.prefix_cache = PrefixCache()
        self.last_call: dict[str, float] = {}  # fast path: reused_tokens, prefill_s, decode_s, new_tokens
        self.source, self.gguf_file, self.model_label = resolve_model(self.model_option, self.cache_dir)
        self._model = None
        self._tokenizer = None
        self._template_used: str | None = None  # 'tokenizer', 'custom', 'plain' or 'raw' once loaded
        self._cache_supported = False  # whether the fast path can run on the loaded model
        self.load_seconds: float | None = None

    def complete(self, prompt: Prompt) -> str:
        return self.complete_messages(prompt.messages)

    def complete_messages(self, messages: list[dict[str, str]]) -> str:
        """Reply to raw chat messages (complete() without a Prompt object)."""
        ids = self._fit(self.encode(messages))
        return self.reply(self.generate_ids(ids))

    def complete_batch(self, prompts: list[Prompt]) -> list[str]:
        """Replies to several prompts from one left-padded generate call (no prefix cache; greedy
        replies equal complete()'s up to rounding, sampled ones differ)."""
        from xicm.plugins.llms.batch_generate import generate_batch

        self.load()
        id_lists = [self._fit(self.encode(p.messages)) for p in prompts]
        if self.do_sample:
            import torch

            torch.manual_seed(self.seed)
        rows = generate_batch(
            self._model, id_lists, self._pad_id(), self._decode, self.rules,
            {**self.generation_kwargs(), **self._grammar_kwargs(len(id_lists))},
        )
        return [self.reply(row) for row in rows]

    def reply(self, new_ids: list[int]) -> str:
        """The reply text of the new token ids: cut at the first stop string, the repeated action
        cut or filled (on_repeated_action), cut after the action list (stop_at_action_list)."""
        return self.rules.reply(self._decode, new_ids)

    def cut_at_stop(self, text: str) -> str:
        """Text up to the first stop string (a reply that starts with one keeps its first line)."""
        return stopping.cut_at_stop(text, self.stop_strings)

    def identity(self) -> str:
        settings: dict[str, Any] = {
            "llm": "transformers_local",
            "model": self.model_label,
            "chat_template": self.chat_template
            if self.chat_template in CHAT_TEMPLATE_MODES
            else "custom:" + hashlib.sha256(self.chat_template.encode()).hexdigest()[:12],
            "stop": self.stop_option,
            "dtype": self.dtype_name,
            "max_new_tokens": self.max_new_tokens,
            "max_prompt_tokens": self.max_prompt_tokens,
            "prompt_overflow": self.prompt_overflow,
            "do_sample": self.do_sample,
        }
        if self.grammar != "none":
            settings["grammar"] = self.grammar
        if self.stop_at_action_list:  # speed options that can change a reply (they cut it)
            settings["stop_at_action_list"] = True
        if self.on_repeated_action != "decode":
            settings["on_repeated_action"] = self.on_repeated_action
        if self.do_sample:
            settings.update(
                temperature=self.temperature, top_p=self.top_p, repetition_penalty=self.repetition_penalty, seed=self.seed
            )
        return json.dumps(settings, sort_keys=True)

    @property
    def deterministic(self) -> bool:
        """True when the same prompt always gets the same reply (greedy or seeded sampling)."""
        return True


@hookimpl
def register_llms(register):
    register("transformers_local", TransformersLocalLLM, options=TransformersLocalOptions)


if __name__ == "__main__":  # print the converted embedded model folder, converting it if needed
    print(model_files.embedded_model_dir())
