"""The prompt of `transformers_local` as token ids: the chat messages rendered (the tokenizer's
or a custom chat template, or `xicm.plugins.llms.rendering`'s plain/raw text), encoded, and
fitted to the prompt limit; the stop strings that go with the rendering. Options:
`xicm.plugins.llms.transformers_local_options`."""

from __future__ import annotations

from xicm.core.contracts.errors import LLMError
from xicm.plugins.llms.local_model import LoadedModel
from xicm.plugins.llms.rendering import fold_system, render_plain, render_raw

ROLE_STOPS = ("\nUser:", "\nSystem:", "\nAssistant:")


class PromptEncoder:
    """Chat messages -> prompt ids that fit, for one `LoadedModel`: reads its tokenizer, the
    rendering it chose and its context length, and the options given here (stop: 'auto', None
    or a list of strings, checked by the LLM)."""

    def __init__(self, loaded: LoadedModel, chat_template: str, stop: str | list[str] | None,
                 max_prompt_tokens: int | None, max_new_tokens: int, prompt_overflow: str):
        self.loaded = loaded
        self.chat_template, self.stop_option = chat_template, stop
        self.max_prompt_tokens, self.max_new_tokens, self.prompt_overflow = max_prompt_tokens, max_new_tokens, prompt_overflow

    def render(self, messages: list[dict[str, str]]) -> str:
        """The exact prompt text the model sees for these messages."""
        self.loaded.load()
        used = self.loaded.template_used
        if used == "plain":
            return render_plain(messages)
        if used == "raw":
            return render_raw(messages)
        template = self.chat_template if used == "custom" else None
        try:
            return self._apply_template(messages, template)
        except Exception as exc:  # jinja2 TemplateError: e.g. "System role not supported"
            if not any(m.get("role") == "system" for m in messages):
                raise LLMError(f"the chat template of {self.loaded.label} failed: {exc}") from exc
            return self._apply_template(fold_system(messages), template)

    def _apply_template(self, messages, template: str | None) -> str:
        return self.loaded.tokenizer.apply_chat_template(
            messages, chat_template=template, add_generation_prompt=True, tokenize=False
        )

    def encode(self, messages: list[dict[str, str]]) -> list[int]:
        """Token ids of the rendered prompt (BOS added for the plain and raw renderings)."""
        text = self.render(messages)
        tokenizer = self.loaded.tokenizer
        if self.loaded.template_used in ("plain", "raw"):
            ids = tokenizer(text, add_special_tokens=True)["input_ids"]
        else:  # templates write their own BOS
            ids = tokenizer(text, add_special_tokens=False)["input_ids"]
        return list(ids)

    @property
    def stop_strings(self) -> list[str]:
        """The stop strings in effect (resolves 'auto' once the template choice is known)."""
        if self.stop_option is None:
            return []
        if self.stop_option != "auto":
            return list(self.stop_option)
        self.loaded.load()
        return {"plain": list(ROLE_STOPS), "raw": ["\n"]}.get(self.loaded.template_used, [])

    def prompt_limit(self) -> int | None:
        if self.max_prompt_tokens is not None:
            return self.max_prompt_tokens
        context = self.loaded.context_length
        return None if context is None else context - self.max_new_tokens

    def fit(self, ids: list[int]) -> list[int]:
        """The ids within the prompt limit: as they are, cut from the left (truncate_left), or LLMError."""
        limit = self.prompt_limit()
        if limit is None or len(ids) <= limit:
            return ids
        if self.prompt_overflow == "truncate_left":
            bos = getattr(self.loaded.tokenizer, "bos_token_id", None)
            if bos is not None and ids and ids[0] == bos and limit > 1:
                return [ids[0], *ids[len(ids) - (limit - 1):]]
            return ids[len(ids) - limit:]
        raise LLMError(
            f"the prompt has {len(ids)} tokens, more than max_prompt_tokens={limit} of {self.loaded.label}; "
            "use fewer demos (policy.k), raise llm.max_prompt_tokens, or set llm.prompt_overflow: truncate_left"
        )
