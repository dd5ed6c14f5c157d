"""`openai_compatible`: any server speaking the OpenAI HTTP API (vLLM, `transformers serve`,
llama.cpp server, Ollama, hosted providers). Hosted models are configuration, not code.

Options (config keys):

base_url ("http://127.0.0.1:8000/v1")
    As in the OpenAI SDK: the URL the endpoint paths are appended to, usually ending in /v1.
model (required)
    The ``model`` field of each request.
api_key_env (None)
    Name of the environment variable holding the API key, sent as ``Authorization: Bearer``.
    Unset or empty variable: no header (fine for local servers).
mode ("chat")
    ``chat``: POST {base_url}/chat/completions with the messages, reply in
    ``choices[0].message.content``. ``completion``: POST {base_url}/completions with the
    messages rendered to one prompt by `xicm.plugins.llms.rendering.render_plain`
    ("System: ...\\n\\nUser: ...\\n\\nAssistant:"), reply in ``choices[0].text``.
completion_format ("plain")
    In completion mode, ``plain`` (above) or ``raw`` (contents joined by a blank line, no role
    labels: `xicm.plugins.llms.rendering.render_raw`, for base models that continue the text).
temperature (0.1), top_p (0.001), max_tokens (256)
    The paper's decoding values; ``null`` leaves a field out of the request.
extra ({})
    More request fields merged into the body (e.g. ``seed``, ``stop``, ``repetition_penalty``).
grammar ("actions")
    ``actions``: each request asks the server to constrain the reply to the action grammar of
    `xicm.plugins.llms.action_grammar` (a list of 1-26 ``[x, y, z, roll, pitch, yaw, gripper]``
    integer groups in range, nothing else), in the field ``server`` names. ``none``: no constraint.
server ("vllm")
    Which structured-output field carries the grammar (merged into the request body; a key of
    ``extra`` with the same name wins):
    ``vllm``: ``"structured_outputs": {"regex": ...}`` (vLLM docs, features/structured_outputs:
    the field that replaced ``guided_regex``, removed in v0.12.0);
    ``sglang``: ``"regex": ...`` (SGLang docs, advanced_features/structured_outputs: one of
    ``json_schema``, ``regex`` or ``ebnf`` per request);
    ``llamacpp``: ``"grammar": <GBNF>`` (llama.cpp tools/server/README.md: the server's
    /completion options, ``grammar`` included, are accepted by /v1/chat/completions;
    grammars/README.md for GBNF);
    ``none``: no field (a server without structured outputs; the grammar is then not enforced).
stop_at_action_list (false)
    true: the reply is cut after its first action list (stopping.first_list_only), as
    transformers_local's option cuts it; false: the whole reply, later lists included (X-ICM).
max_actions (null)
    With the grammar on: replies are lists of at most this many actions (1-26; null: 26, the most
    X-ICM's reader keeps). The grammar then allows only the list's end, so a reply that would
    repeat an action on to the token budget stops there: fewer tokens decoded, and a reply longer
    than the bound is its first max_actions actions. In identity() when set.
timeout_s (120)
    Timeout of one attempt (connect, and each read), in seconds.
retries (3)
    Retries after the first attempt, made by the `openai` client (its ``max_retries``): on
    connection errors, timeouts and HTTP 408/409/429/5xx, after its exponential backoff (or
    the server's Retry-After). Other HTTP errors (400, 401, 404, ...) and replies that are not
    JSON or hold no text fail at once. A failure raises xicm.core.contracts.errors.LLMError
    with one sentence (the episode ends with error kind ``llm_error`` and the run goes on).

When a run starts, the server is asked once for its model list (``check_ready``): a server that
does not answer, refuses the key, or does not serve ``model`` stops the run with one sentence
before any episode (instead of every episode waiting for its retries and ending in llm_error).

The HTTP client is the ``openai`` package (``pip install 'xicm[llm]'``), imported when the
plugin is created, not when it is registered.
"""

from __future__ import annotations

import json
import os
from typing import Any

from xicm.core.contracts.errors import ConfigError, LLMError
from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.interfaces import LLM
from xicm.core.contracts.types import Prompt
from xicm.plugins.llms.action_grammar import check_grammar, reply_gbnf, reply_regex
from xicm.plugins.llms.stopping import first_list_only
from xicm.plugins.llms.openai_compatible_options import SERVERS, OpenAICompatibleOptions
from xicm.plugins.llms.rendering import render_plain, render_raw

MODES = {"chat": "/chat/completions", "completion": "/completions"}


class OpenAICompatibleLLM(LLM):
    """Client of an OpenAI-compatible HTTP endpoint (the `openai` package's client)."""

    def __init__(self, options: OpenAICompatibleOptions):
        o = options
        model, base_url, mode, completion_format, server = o.model, o.base_url, o.mode, o.completion_format, o.server
        if not model:
            raise ConfigError("llm 'openai_compatible' needs a model name (llm.model), e.g. the server's model id")
        if mode not in MODES:
            raise ConfigError(f"llm.mode '{mode}' is unknown; available: {', '.join(MODES)}")
        if completion_format not in ("plain", "raw"):
            raise ConfigError(f"llm.completion_format '{completion_format}' is unknown; available: plain, raw")
        if server not in SERVERS:
            raise ConfigError(f"llm.server '{server}' is unknown; available: {', '.join(SERVERS)}")
        self.grammar = check_grammar(o.grammar)
        self.server = server
        self.stop_at_action_list = o.stop_at_action_list
        self.max_actions = o.max_actions
        if not str(base_url).startswith(("http://", "https://")):
            raise ConfigError(f"llm.base_url '{base_url}' is not an http(s) URL")
        try:
            import openai
        except ImportError:
            raise ConfigError("llm 'openai_compatible' needs the openai package: pip install 'xicm[llm]'") from None
        self.model = str(model)
        self.base_url = str(base_url).rstrip("/")
        self.mode = mode
        self.completion_format = completion_format
        self.temperature = o.temperature
        self.top_p = o.top_p
        self.max_tokens = o.max_tokens
        self.extra = dict(o.extra or {})
        self.timeout_s = float(o.timeout_s)
        self.retries = o.retries
        self.attempts_made = 0  # HTTP requests sent by the last call, retries included
        self.last_reply = None  # the last parsed reply (usage; a server's own fields in model_extra)
        api_key = os.environ.get(o.api_key_env, "") if o.api_key_env else ""
        # No key (fine for local servers): no Authorization header at all, as openai allows
        # only when a request omits the header explicitly.
        self._no_auth = {} if api_key else {"Authorization": openai.Omit()}
        self._openai = openai
        self._client = openai.OpenAI(
            base_url=self.base_url,
            api_key=api_key or "unused",
            timeout=self.timeout_s,
            max_retries=self.retries,
            http_client=openai.DefaultHttpxClient(event_hooks={"request": [self._count_attempt]}),
        )

    def _count_attempt(self, _request) -> None:
        self.attempts_made += 1

    @property
    def url(self) -> str:
        return self.base_url + MODES[self.mode]

    @property
    def deterministic(self) -> bool:
        """Whether replies can be cached: temperature 0, or top_p so small only the top token remains."""
        return (self.temperature is not None and self.temperature == 0) or (
            self.top_p is not None and self.top_p <= 0.001
        )

    def request(self, messages: list[dict[str, str]], anchored: bool = False) -> dict[str, Any]:
        """The keyword arguments of the openai create() call; `extra` goes into the body as is.
        `anchored`: the prompt writes anchored actions (Prompt.anchors), so the grammar is theirs."""
        request: dict[str, Any] = {"model": self.model, "stream": False}
        if self.mode == "chat":
            request["messages"] = [{"role": m["role"], "content": m["content"]} for m in messages]
        else:
            render = render_plain if self.completion_format == "plain" else render_raw
            request["prompt"] = render(messages)
        for key in ("temperature", "top_p", "max_tokens"):
            value = getattr(self, key)
            if value is not None:
                request[key] = value
        return {**request, "extra_body": {**self.grammar_fields(anchored), **self.extra}, "extra_headers": self._no_auth}

    def grammar_fields(self, anchored: bool = False) -> dict[str, Any]:
        """The body fields that ask `server` for the action grammar (none when grammar is none)."""
        if self.grammar == "none" or self.server == "none":
            return {}
        return {
            "vllm": {"structured_outputs": {"regex": reply_regex(anchored, self.max_actions)}},
            "sglang": {"regex": reply_regex(anchored, self.max_actions)},
            "llamacpp": {"grammar": reply_gbnf(anchored, self.max_actions)},
        }[self.server]

    def _grammar_hint(self, exc) -> str:
        """When a server refuses the request over its structured-output field (e.g. `transformers
        serve` answers 422 to vLLM's field), say which option to change."""
        fields = self.grammar_fields()
        if exc.status_code in (400, 422) and any(name in exc.response.text for name in fields):
            return (f"; the server did not take llm.server={self.server}'s structured-output field: set llm.server "
                    f"to its kind ({', '.join(s for s in SERVERS if s != 'none')}) or none (llm.grammar is then not enforced)")
        return ""

    def complete(self, prompt: Prompt) -> str:
        return self.complete_messages(prompt.messages, anchored=prompt.anchors is not None)

    def check_ready(self) -> None:
        """Ask the server once for its model list (GET {base_url}/models, no retries): a server
        that does not answer, refuses the key, or does not serve `model` stops the run here.
        A server without that endpoint (404/405/501) cannot be checked and is trusted."""
        openai = self._openai
        client = self._client.with_options(max_retries=0, timeout=min(self.timeout_s, 15.0))
        where = f"{self.base_url}/models"
        try:
            served = [m.id for m in client.models.list(extra_headers=self._no_auth)]
        except openai.APIConnectionError as exc:  # timeouts included
            raise ConfigError(f"llm.base_url: no OpenAI-compatible server answered at {where} ({exc.__cause__ or exc})") from None
        except openai.APIStatusError as exc:
            if exc.status_code in (404, 405, 501):
                return
            raise ConfigError(f"llm.base_url: {where} answered HTTP {exc.status_code}{_error_detail(exc.response.text)}") from None
        except (json.JSONDecodeError, openai.APIResponseValidationError):
            return  # not a model list: nothing to check against
        if served and self.model not in served:
            shown = ", ".join(served[:10]) + (" ..." if len(served) > 10 else "")
            raise ConfigError(f"llm.model '{self.model}' is not served at {self.base_url}; it serves: {shown}")

    def complete_messages(self, messages: list[dict[str, str]], anchored: bool = False) -> str:
        """Reply to raw chat messages (the client retries transient failures); `anchored` as in request()."""
        openai = self._openai
        endpoint = self._client.chat.completions if self.mode == "chat" else self._client.completions
        self.attempts_made = 0
        try:
            reply = endpoint.create(**self.request(messages, anchored))
        except openai.APITimeoutError:
            reason = f"no reply within timeout_s={self.timeout_s:g}"
        except openai.APIConnectionError as exc:
            reason = f"cannot connect ({exc.__cause__ or exc})"
        except openai.APIStatusError as exc:
            reason = f"HTTP {exc.status_code}{_error_detail(exc.response.text)}{self._grammar_hint(exc)}"
        except (json.JSONDecodeError, openai.APIResponseValidationError) as exc:
            reason = f"reply is not JSON ({' '.join(str(exc).split())[:120]})"
        else:
            self.last_reply = reply
            text = self._text(reply)
            return first_list_only(text) if self.stop_at_action_list else text
        raise LLMError(f"{self.url} failed after {self.attempts_made} attempt(s): {reason}")

    def _text(self, reply) -> str:
        where = "choices[0].message.content" if self.mode == "chat" else "choices[0].text"
        try:
            choice = reply.choices[0]
            text = _given(choice.message, "content") if self.mode == "chat" else _given(choice, "text")
        except (AttributeError, IndexError, TypeError):
            raise LLMError(f"{self.url} sent a reply with no {where}: {_shown(reply)}") from None
        if text is None:
            return ""
        if not isinstance(text, str):
            raise LLMError(f"{self.url} sent a reply whose {where} is a {type(text).__name__}, not a string")
        return text

    def identity(self) -> str:
        constraint = {"grammar": self.grammar, "server": self.server} if self.grammar_fields() else {}
        if constraint and self.max_actions is not None:
            constraint["max_actions"] = self.max_actions
        cut = {"stop_at_action_list": True} if self.stop_at_action_list else {}
        return json.dumps(
            {
                **constraint,
                **cut,
                "llm": "openai_compatible",
                "base_url": self.base_url,
                "model": self.model,
                "mode": self.mode,
                "completion_format": self.completion_format if self.mode == "completion" else None,
                "temperature": self.temperature,
                "top_p": self.top_p,
                "max_tokens": self.max_tokens,
                "extra": self.extra,
            },
            sort_keys=True,
        )


def _given(model, field: str):
    """model.field if the reply had that key (null included); the client reads a missing key as None."""
    if field not in model.model_fields_set:
        raise AttributeError(field)
    return getattr(model, field)


def _shown(reply) -> str:
    try:
        text = reply.model_dump_json(exclude_none=True, warnings=False)
    except Exception:  # noqa: BLE001 - only for the error message
        text = repr(reply)
    return text[:120]


def _error_detail(text: str) -> str:
    """' (message)' from an error body: its error.message when it is JSON, else the text."""
    text = (text or "").strip()
    if not text:
        return ""
    try:
        parsed = json.loads(text)
        message = parsed.get("error", parsed)
        if isinstance(message, dict):
            message = message.get("message", message)
        text = str(message)
    except (json.JSONDecodeError, AttributeError):
        pass
    return f" ({' '.join(text.split())[:160]})"


@hookimpl
def register_llms(register):
    register("openai_compatible", OpenAICompatibleLLM, options=OpenAICompatibleOptions)
