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
timeout_s (120)
    Socket timeout of one attempt (connect, and each read).
retries (3), backoff_s (1.0)
    Retries after the first attempt on connection errors, timeouts, HTTP 408/409/429/5xx and
    malformed replies, sleeping backoff_s * 2**attempt in between. Other HTTP errors (400,
    401, 404, ...) fail at once. A failure raises xicm.core.errors.LLMError with one sentence
    (the episode ends with error kind ``llm_error`` and the run goes on).
"""

from __future__ import annotations

import json
import os
import socket
import time
import urllib.error
import urllib.request
from typing import Any

from xicm.core.errors import ConfigError, LLMError
from xicm.core.hookspecs import hookimpl
from xicm.core.interfaces import LLM
from xicm.core.types import Prompt
from xicm.plugins.llms.openai_compatible_options import OpenAICompatibleOptions
from xicm.plugins.llms.options import to_plain
from xicm.plugins.llms.rendering import render_plain, render_raw

MODES = {"chat": "/chat/completions", "completion": "/completions"}
RETRY_STATUS = {408, 409, 429, 500, 502, 503, 504}


class _Retryable(Exception):
    """An attempt failed in a way that may pass on retry."""


class OpenAICompatibleLLM(LLM):
    """Client of an OpenAI-compatible HTTP endpoint (stdlib urllib, no SDK)."""

    def __init__(
        self,
        model: str | None = None,
        base_url: str = "http://127.0.0.1:8000/v1",
        api_key_env: str | None = None,
        mode: str = "chat",
        completion_format: str = "plain",
        temperature: float | None = 0.1,
        top_p: float | None = 0.001,
        max_tokens: int | None = 256,
        extra: dict[str, Any] | None = None,
        timeout_s: float = 120.0,
        retries: int = 3,
        backoff_s: float = 1.0,
    ):
        if not model:
            raise ConfigError("llm 'openai_compatible' needs a model name (llm.model), e.g. the server's model id")
        if mode not in MODES:
            raise ConfigError(f"llm.mode '{mode}' is unknown; available: {', '.join(MODES)}")
        if completion_format not in ("plain", "raw"):
            raise ConfigError(f"llm.completion_format '{completion_format}' is unknown; available: plain, raw")
        if not str(base_url).startswith(("http://", "https://")):
            raise ConfigError(f"llm.base_url '{base_url}' is not an http(s) URL")
        self.model = str(model)
        self.base_url = str(base_url).rstrip("/")
        self.api_key_env = api_key_env
        self.mode = mode
        self.completion_format = completion_format
        self.temperature = temperature
        self.top_p = top_p
        self.max_tokens = max_tokens
        self.extra = to_plain(dict(extra or {}))
        self.timeout_s = float(timeout_s)
        self.retries = max(0, int(retries))
        self.backoff_s = float(backoff_s)
        self.attempts_made = 0  # attempts of the last call (for tests and logs)

    @property
    def url(self) -> str:
        return self.base_url + MODES[self.mode]

    @property
    def deterministic(self) -> bool:
        """Whether replies can be cached: temperature 0, or top_p so small only the top token remains."""
        return (self.temperature is not None and self.temperature == 0) or (
            self.top_p is not None and self.top_p <= 0.001
        )

    def body(self, messages: list[dict[str, str]]) -> dict[str, Any]:
        body: dict[str, Any] = {"model": self.model}
        if self.mode == "chat":
            body["messages"] = [{"role": m["role"], "content": m["content"]} for m in messages]
        else:
            render = render_plain if self.completion_format == "plain" else render_raw
            body["prompt"] = render(messages)
        for key in ("temperature", "top_p", "max_tokens"):
            value = getattr(self, key)
            if value is not None:
                body[key] = value
        body.update(self.extra)
        body["stream"] = False
        return body

    def _headers(self) -> dict[str, str]:
        headers = {"Content-Type": "application/json", "Accept": "application/json"}
        key = os.environ.get(self.api_key_env, "") if self.api_key_env else ""
        if key:
            headers["Authorization"] = f"Bearer {key}"
        return headers

    def complete(self, prompt: Prompt) -> str:
        return self.complete_messages(prompt.messages)

    def complete_messages(self, messages: list[dict[str, str]]) -> str:
        """Reply to raw chat messages, retrying transient failures."""
        data = json.dumps(self.body(messages)).encode()
        last = "no attempt made"
        self.attempts_made = 0
        for attempt in range(self.retries + 1):
            if attempt:
                time.sleep(self.backoff_s * 2 ** (attempt - 1))
            self.attempts_made += 1
            try:
                return self._attempt(data)
            except _Retryable as exc:
                last = str(exc)
        raise LLMError(f"{self.url} failed after {self.attempts_made} attempt(s): {last}")

    def _attempt(self, data: bytes) -> str:
        request = urllib.request.Request(self.url, data=data, headers=self._headers(), method="POST")
        try:
            with urllib.request.urlopen(request, timeout=self.timeout_s) as response:
                raw = response.read()
        except urllib.error.HTTPError as exc:
            detail = _error_detail(exc)
            if exc.code in RETRY_STATUS:
                raise _Retryable(f"HTTP {exc.code}{detail}") from None
            raise LLMError(f"{self.url} answered HTTP {exc.code}{detail}") from None
        except (TimeoutError, socket.timeout):
            raise _Retryable(f"no reply within timeout_s={self.timeout_s:g}") from None
        except urllib.error.URLError as exc:
            reason = exc.reason
            if isinstance(reason, (TimeoutError, socket.timeout)):
                raise _Retryable(f"no reply within timeout_s={self.timeout_s:g}") from None
            raise _Retryable(f"cannot connect ({reason})") from None
        except (ConnectionError, OSError) as exc:  # reset / closed mid-reply
            raise _Retryable(f"connection error ({exc})") from None
        return self._extract(raw)

    def _extract(self, raw: bytes) -> str:
        try:
            reply = json.loads(raw)
        except (json.JSONDecodeError, UnicodeDecodeError):
            raise _Retryable(f"reply is not JSON: {raw[:80]!r}") from None
        try:
            choice = reply["choices"][0]
            text = choice["message"]["content"] if self.mode == "chat" else choice["text"]
        except (KeyError, IndexError, TypeError):
            where = "choices[0].message.content" if self.mode == "chat" else "choices[0].text"
            raise _Retryable(f"reply has no {where}: {json.dumps(reply)[:120]}") from None
        if text is None:
            text = ""
        if not isinstance(text, str):
            raise _Retryable(f"reply text is a {type(text).__name__}, not a string")
        return text

    def identity(self) -> str:
        return json.dumps(
            {
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


def _error_detail(exc: urllib.error.HTTPError) -> str:
    try:
        text = exc.read().decode("utf-8", "replace").strip()
    except Exception:
        text = ""
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
