"""openai_compatible (the `openai` package's client) against real HTTP servers on 127.0.0.1.

Fast tests use a scripted OpenAI-protocol server (http.server in a thread) to exercise
retries, timeouts, HTTP errors and malformed replies deterministically (retries wait the
client's backoff, about 0.5 s, 1 s, 2 s). The slow tests start `transformers serve` on the
converted embedded Gemma 3 270M folder.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import pluggy
import pytest

from xicm.core.contracts import hookspecs
from xicm.core.contracts.errors import ConfigError, LLMError
from xicm.core.assembly.plugins import Registry
from xicm.core.contracts.types import Prompt, Query
from xicm.plugins.llms import openai_compatible
from xicm.plugins.llms.action_grammar import ACTIONS_GBNF, ACTIONS_REGEX
from xicm.plugins.llms.openai_compatible import OpenAICompatibleLLM
from xicm.plugins.llms.openai_compatible_options import OpenAICompatibleOptions
from xicm.plugins.llms.rendering import render_plain, render_raw
from xicm.serving.ports import free_port, stop_process, wait_http_ok

WS = ((-0.3, -0.5, 0.6), (0.7, 0.5, 1.6))
MESSAGES = [
    {"role": "system", "content": "You are a Franka Panda robot."},
    {"role": "user", "content": "close the red jar, jar [50, 20, 10]>"},
]


def make_prompt(messages=MESSAGES) -> Prompt:
    return Prompt(messages=list(messages), demos=[], query=Query(task="t", instruction="i", objects={}), workspace=WS)


class FakeOpenAI:
    """A scripted OpenAI-protocol server. Each request consumes the next step of `script`;
    when the script is empty it answers normally."""

    def __init__(self):
        self.script: list[tuple] = []
        self.requests: list[dict] = []
        self.reply = "[[1, 2, 3, 4, 5, 6, 1]]"
        self.constrained_reply: str | None = None  # the reply when a request carries a structured-output field
        self.models: list[str] | int = ["test-model"]  # GET /models: the served ids, or an HTTP status
        fake = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args):
                pass

            def do_GET(self):
                fake.requests.append({"path": self.path, "headers": {k.lower(): v for k, v in self.headers.items()}, "body": None})
                if not self.path.endswith("/models"):
                    self._send(404, b"{}")
                elif isinstance(fake.models, int):
                    self._send(fake.models, json.dumps({"error": {"message": "no"}}).encode())
                else:
                    data = [{"id": m, "object": "model", "created": 0, "owned_by": "test"} for m in fake.models]
                    self._send(200, json.dumps({"object": "list", "data": data}).encode())

            def do_POST(self):
                length = int(self.headers.get("Content-Length", 0))
                body = json.loads(self.rfile.read(length) or b"{}")
                headers = {k.lower(): v for k, v in self.headers.items()}  # HTTP header names are case-insensitive
                fake.requests.append({"path": self.path, "headers": headers, "body": body})
                step = fake.script.pop(0) if fake.script else ("ok",)
                kind = step[0]
                if kind == "sleep":
                    time.sleep(step[1])
                    step = ("ok",)
                    kind = "ok"
                if kind == "status":
                    payload = json.dumps({"error": {"message": step[2] if len(step) > 2 else "boom"}}).encode()
                    self._send(step[1], payload)
                elif kind == "raw":
                    self._send(200, step[1])
                elif kind == "ok":
                    constrained = any(k in body for k in ("structured_outputs", "regex", "grammar"))
                    text = fake.constrained_reply if constrained and fake.constrained_reply else fake.reply
                    if self.path.endswith("/chat/completions"):
                        choice = {"index": 0, "message": {"role": "assistant", "content": text}}
                    else:
                        choice = {"index": 0, "text": text}
                    self._send(200, json.dumps({"object": "x", "choices": [choice]}).encode())

            def _send(self, code, payload: bytes):
                try:
                    self.send_response(code)
                    self.send_header("Content-Type", "application/json")
                    self.send_header("Content-Length", str(len(payload)))
                    self.end_headers()
                    self.wfile.write(payload)
                except (BrokenPipeError, ConnectionResetError):
                    pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.server.daemon_threads = True
        self.port = self.server.server_address[1]
        self.base_url = f"http://127.0.0.1:{self.port}/v1"
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)
        self.thread.start()

    def close(self):
        self.server.shutdown()
        self.server.server_close()


@pytest.fixture
def fake():
    server = FakeOpenAI()
    yield server
    server.close()


def llm(fake, **kw) -> OpenAICompatibleLLM:
    options = {"model": "test-model", "base_url": fake.base_url, "timeout_s": 5.0}
    options.update(kw)
    return OpenAICompatibleLLM(OpenAICompatibleOptions(**options))


def test_chat_mode_request_and_reply(fake):
    client = llm(fake, extra={"seed": 7, "repetition_penalty": 1.05})
    assert client.complete(make_prompt()) == fake.reply
    (req,) = fake.requests
    assert req["path"] == "/v1/chat/completions"
    body = req["body"]
    assert body["model"] == "test-model"
    assert body["messages"] == MESSAGES
    assert (body["temperature"], body["top_p"], body["max_tokens"]) == (0.1, 0.001, 256)
    assert body["seed"] == 7 and body["repetition_penalty"] == 1.05 and body["stream"] is False
    assert "authorization" not in req["headers"]


def test_completion_mode_renders_one_prompt(fake):
    client = llm(fake, mode="completion", temperature=None, max_tokens=32)
    assert client.complete(make_prompt()) == fake.reply
    req = fake.requests[0]
    assert req["path"] == "/v1/completions"
    assert req["body"]["prompt"] == render_plain(MESSAGES)
    assert req["body"]["prompt"].endswith("close the red jar, jar [50, 20, 10]>\n\nAssistant:")
    assert "temperature" not in req["body"] and req["body"]["max_tokens"] == 32
    llm(fake, mode="completion", completion_format="raw").complete(make_prompt())
    assert fake.requests[1]["body"]["prompt"] == render_raw(MESSAGES)


def test_api_key_from_named_env_var(fake, monkeypatch):
    monkeypatch.setenv("XICM_TEST_KEY", "sk-test")
    llm(fake, api_key_env="XICM_TEST_KEY").complete(make_prompt())
    assert fake.requests[-1]["headers"]["authorization"] == "Bearer sk-test"
    monkeypatch.delenv("XICM_TEST_KEY")
    llm(fake, api_key_env="XICM_TEST_KEY").complete(make_prompt())  # missing key: fine for local servers
    assert "authorization" not in fake.requests[-1]["headers"]


def test_retries_500_and_429_then_succeeds(fake):
    fake.script = [("status", 500), ("status", 429), ("status", 503)]
    client = llm(fake, retries=3)
    assert client.complete(make_prompt()) == fake.reply
    assert client.attempts_made == 4 and len(fake.requests) == 4


def test_gives_up_after_retries_with_one_sentence(fake):
    fake.script = [("status", 500, "CUDA out of memory")] * 3
    client = llm(fake, retries=2)
    with pytest.raises(LLMError) as info:
        client.complete(make_prompt())
    message = str(info.value)
    assert "failed after 3 attempt(s)" in message and "HTTP 500" in message and "CUDA out of memory" in message
    assert "\n" not in message
    assert len(fake.requests) == 3


def test_client_errors_are_not_retried(fake):
    fake.script = [("status", 404, "model 'test-model' not found")]
    client = llm(fake, retries=3)
    with pytest.raises(LLMError, match=r"HTTP 404 \(model 'test-model' not found\)"):
        client.complete(make_prompt())
    assert len(fake.requests) == 1


def test_a_reply_that_is_not_json_fails_at_once(fake):
    fake.script = [("raw", b"<html>oops")]
    with pytest.raises(LLMError, match=r"failed after 1 attempt\(s\): reply is not JSON \(Expecting value"):
        llm(fake, retries=1).complete(make_prompt())
    assert len(fake.requests) == 1


def test_reply_without_text_is_reported(fake):
    fake.script = [("raw", b'{"object": "error"}')]
    with pytest.raises(LLMError, match=r"sent a reply with no choices\[0\]\.message\.content: \{\"object\":\"error\"\}$"):
        llm(fake, retries=1).complete(make_prompt())
    fake.script = [("raw", b'{"choices": [{"message": {}}]}')]
    with pytest.raises(LLMError, match=r"no choices\[0\]\.message\.content"):
        llm(fake).complete(make_prompt())
    fake.script = [("raw", b'{"choices": [{"message": {"content": "hi"}}]}')]
    with pytest.raises(LLMError, match=r"no choices\[0\]\.text"):
        llm(fake, retries=0, mode="completion").complete(make_prompt())
    fake.script = [("raw", b'{"choices": [{"message": {"content": 5}}]}')]
    with pytest.raises(LLMError, match=r"content is a int, not a string"):
        llm(fake).complete(make_prompt())
    assert len(fake.requests) == 4  # none of them retried


def test_a_null_text_is_an_empty_reply(fake):
    fake.script = [("raw", b'{"choices": [{"message": {"content": null}}]}')]
    assert llm(fake).complete(make_prompt()) == ""


def test_timeout_is_bounded_and_retried(fake):
    fake.script = [("sleep", 3.0), ("sleep", 3.0)]
    client = llm(fake, timeout_s=0.3, retries=1)
    start = time.monotonic()
    with pytest.raises(LLMError, match=r"failed after 2 attempt\(s\): no reply within timeout_s=0\.3"):
        client.complete(make_prompt())
    assert time.monotonic() - start < 2.5  # 2 x 0.3 s and one backoff, not a 3 s reply
    assert client.attempts_made == 2
    fake.script = [("sleep", 1.0)]
    assert llm(fake, timeout_s=0.3, retries=1).complete(make_prompt()) == fake.reply


def test_unreachable_server():
    port = free_port()  # nothing listens there
    client = OpenAICompatibleLLM(OpenAICompatibleOptions(model="m", base_url=f"http://127.0.0.1:{port}/v1", retries=1))
    with pytest.raises(LLMError, match=r"failed after 2 attempt\(s\): cannot connect \(.*refused"):
        client.complete(make_prompt())


def test_the_server_is_checked_once_at_start(fake):
    llm(fake).check_ready()  # serves test-model: fine
    assert fake.requests[-1]["path"] == "/v1/models"
    fake.models = ["Qwen/Qwen2.5-7B-Instruct", "other"]
    with pytest.raises(ConfigError, match=r"llm.model 'test-model' is not served at http://127.0.0.1:\d+/v1; it serves: Qwen/Qwen2.5-7B-Instruct, other"):
        llm(fake).check_ready()
    fake.models = 401
    with pytest.raises(ConfigError, match=r"/v1/models answered HTTP 401"):
        llm(fake).check_ready()
    fake.models = 404  # a server without a model list cannot be checked: trusted
    llm(fake).check_ready()
    assert not [r for r in fake.requests if r["path"].endswith("completions")]  # checking sends no completion


def test_a_dead_server_is_one_sentence_at_start_without_retries():
    port = free_port()
    start = time.perf_counter()
    with pytest.raises(ConfigError, match=rf"llm.base_url: no OpenAI-compatible server answered at http://127.0.0.1:{port}/v1/models"):
        OpenAICompatibleLLM(OpenAICompatibleOptions(model="m", base_url=f"http://127.0.0.1:{port}/v1", retries=3)).check_ready()
    assert time.perf_counter() - start < 5  # no retries with backoff


def test_config_errors_and_registration():
    with pytest.raises(ConfigError, match="needs a model name"):
        OpenAICompatibleLLM(OpenAICompatibleOptions(base_url="http://127.0.0.1:1/v1"))
    with pytest.raises(ConfigError, match="available: chat, completion"):
        OpenAICompatibleLLM(OpenAICompatibleOptions(model="m", mode="stream"))
    with pytest.raises(ConfigError, match="not an http"):
        OpenAICompatibleLLM(OpenAICompatibleOptions(model="m", base_url="127.0.0.1:8000"))
    pm = pluggy.PluginManager("xicm")
    pm.add_hookspecs(hookspecs)
    pm.register(openai_compatible, name="xicm.plugins.llms.openai_compatible")
    registry = Registry(pm)
    client = registry.create("llm", {"name": "openai_compatible", "model": "m", "base_url": "http://h:1/v1/"})
    assert client.url == "http://h:1/v1/chat/completions"
    identity = json.loads(client.identity())
    assert identity["model"] == "m" and identity["temperature"] == 0.1 and identity["mode"] == "chat"
    assert client.deterministic  # top_p 0.001
    assert not OpenAICompatibleLLM(OpenAICompatibleOptions(model="m", temperature=0.7, top_p=0.9)).deterministic
    with pytest.raises(ConfigError, match="unknown option.*timeout"):
        registry.create("llm", {"name": "openai_compatible", "model": "m", "timeout": 3})
    with pytest.raises(ConfigError, match="unknown option.*backoff_s"):  # the openai client's backoff is not configurable
        registry.create("llm", {"name": "openai_compatible", "model": "m", "backoff_s": 1.0})


# ---------------------------------------------------------------- real `transformers serve`
@pytest.fixture(scope="module")
def served_model(tmp_path_factory):
    """`transformers serve` on the embedded model: (model folder, base URL)."""
    pytest.importorskip("fastapi")
    pytest.importorskip("uvicorn")
    from transformers.utils.import_utils import is_serve_available

    if not is_serve_available():
        pytest.skip("transformers serve needs fastapi, uvicorn, pydantic and openai")
    from xicm.plugins.llms.model_files import embedded_model_dir

    folder = embedded_model_dir()  # converts on first use (~80 s), then cached
    cli = shutil.which("transformers", path=str(Path(sys.executable).parent)) or shutil.which("transformers")
    assert cli, "the transformers console script is not installed"
    port = free_port()
    env = dict(os.environ, HF_HUB_OFFLINE="1")
    log = open(tmp_path_factory.mktemp("serve") / "serve.log", "w+")
    proc = subprocess.Popen(
        [cli, "serve", str(folder), "--host", "127.0.0.1", "--port", str(port), "--device", "cpu"],
        stdout=log,
        stderr=subprocess.STDOUT,
        env=env,
    )
    try:
        ready_s = wait_http_ok(f"http://127.0.0.1:{port}/health", proc, timeout_s=180)
        print(f"\ntransformers serve: ready after {ready_s:.0f} s")
        yield folder, f"http://127.0.0.1:{port}/v1"
    finally:
        stop_process(proc, timeout_s=30)
        log.seek(0)
        print(log.read()[-3000:])
        log.close()


SERVED_MESSAGES = [{
    "role": "user",
    "content": "close the red jar, jar [50, 20, 10], lid [40, 30, 10]>[[40, 30, 20, 0, 36, 0, 1]]\n"
    "close the blue jar, jar [30, 60, 10], lid [45, 35, 10]>",
}]


@pytest.mark.slow
@pytest.mark.llm_model
def test_transformers_serve_completes_greedily_the_same_twice(served_model, capsys):
    folder, base = served_model
    # The server is pinned to the folder: the request's model must be that path.
    completion = OpenAICompatibleLLM(OpenAICompatibleOptions(model=str(folder), base_url=base, mode="completion", completion_format="raw", temperature=0.0, top_p=None, max_tokens=24, timeout_s=300, retries=1, server="none"))
    start = time.monotonic()
    first = completion.complete(make_prompt(SERVED_MESSAGES))
    first_s = time.monotonic() - start
    second = completion.complete(make_prompt(SERVED_MESSAGES))
    with capsys.disabled():
        print(f"\ntransformers serve: first completion {first_s:.1f} s, reply {first!r}")
    assert isinstance(first, str) and first.strip()
    assert first == second  # greedy: same reply twice


@pytest.mark.slow
@pytest.mark.llm_model
def test_transformers_serve_refuses_chat_for_a_model_without_chat_template(served_model):
    folder, base = served_model
    chat = OpenAICompatibleLLM(OpenAICompatibleOptions(model=str(folder), base_url=base, mode="chat", max_tokens=8, timeout_s=120, retries=0, server="none"))
    # transformers serve answered HTTP 500 up to transformers 5.24 and 400 from 5.25 (a fresh install on 2026-12-03)
    with pytest.raises(LLMError, match=r"/v1/chat/completions failed after 1 attempt\(s\): HTTP (?:400|500)"):
        chat.complete(make_prompt(SERVED_MESSAGES))


@pytest.mark.slow
@pytest.mark.llm_model
def test_transformers_serve_refusing_the_grammar_field_names_the_option_to_change(served_model):
    """`transformers serve` has no structured outputs and refuses vLLM's field (HTTP 422): the
    episode's error says to set llm.server, instead of only the server's complaint."""
    folder, base = served_model
    llm = OpenAICompatibleLLM(OpenAICompatibleOptions(model=str(folder), base_url=base, mode="completion", completion_format="raw", max_tokens=4, timeout_s=120, retries=0))  # grammar actions, server vllm: the defaults
    with pytest.raises(LLMError, match=r"HTTP 422 .*structured_outputs.*; the server did not take llm.server=vllm's "
                                       r"structured-output field: set llm.server to its kind \(vllm, sglang, llamacpp\) or none"):
        llm.complete(make_prompt(SERVED_MESSAGES))


def test_hydra_style_options_are_plain_json(fake):
    """The registry hands the LLM its options as plain values, however the config held them."""
    from omegaconf import OmegaConf

    from xicm.core.assembly.plugins import get_registry

    options = OmegaConf.create({"name": "openai_compatible", "model": "test-model", "base_url": fake.base_url,
                                "extra": {"stop": ["\n"], "seed": 1}})
    client = get_registry().create("llm", options)
    client.complete(make_prompt())
    assert fake.requests[-1]["body"]["stop"] == ["\n"] and fake.requests[-1]["body"]["seed"] == 1
    assert json.loads(client.identity())["extra"] == {"seed": 1, "stop": ["\n"]}


GRAMMAR_FIELDS = ("structured_outputs", "regex", "grammar")


@pytest.mark.parametrize(
    "server, expected",
    [
        ("vllm", {"structured_outputs": {"regex": ACTIONS_REGEX}}),
        ("sglang", {"regex": ACTIONS_REGEX}),
        ("llamacpp", {"grammar": ACTIONS_GBNF}),
        ("none", {}),
    ],
)
def test_the_grammar_goes_in_the_servers_structured_output_field(fake, server, expected):
    """The scripted server answers prose unless the request carries a structured-output field."""
    import re

    from xicm.core.text.parsing import ParseError, parse_actions

    fake.reply = "Sure! The robot should move to the jar and then close it."
    fake.constrained_reply = " [[50, 20, 14, 0, 36, 71, 1], [50, 20, 10, 0, 36, 71, 0]]"
    reply = llm(fake, server=server, mode="completion", completion_format="raw").complete(make_prompt())
    body = fake.requests[-1]["body"]
    assert {k: body[k] for k in GRAMMAR_FIELDS if k in body} == expected
    if expected:
        assert reply == fake.constrained_reply and re.fullmatch(ACTIONS_REGEX, reply)
        assert len(parse_actions(reply, WS)) == 2
    else:  # no field: the server decodes freely and the reply is a parse error
        assert isinstance(parse_actions(reply, WS), ParseError)


def test_max_actions_bounds_the_list_in_every_servers_field(fake):
    import re

    from xicm.plugins.llms.action_grammar import reply_gbnf, reply_regex

    two = "[[1, 2, 3, 0, 0, 0, 1], [4, 5, 6, 0, 0, 0, 0]]"
    assert re.fullmatch(reply_regex(False, 2), two) and not re.fullmatch(reply_regex(False, 1), two)
    assert re.fullmatch(reply_regex(False, 26), two) and reply_regex(False, 26) == ACTIONS_REGEX
    assert "{0,1}" in reply_gbnf(False, 2).splitlines()[0] and reply_gbnf(False, None) == ACTIONS_GBNF
    for server, path in (("vllm", ("structured_outputs", "regex")), ("sglang", ("regex",)), ("llamacpp", ("grammar",))):
        bounded = llm(fake, server=server, max_actions=2)
        bounded.complete(make_prompt())
        field = fake.requests[-1]["body"]
        for key in path:
            field = field[key]
        assert field == (reply_gbnf(False, 2) if server == "llamacpp" else reply_regex(False, 2))
        assert json.loads(bounded.identity())["max_actions"] == 2
    assert "max_actions" not in json.loads(llm(fake, server="vllm").identity())
    from xicm.core.contracts.schema import check_options

    with pytest.raises(ConfigError, match="max_actions"):  # checked with the config, before a run starts
        check_options({"model": "m", "max_actions": 27}, OpenAICompatibleOptions, "llm", "llm 'openai_compatible'")


def test_grammar_none_sends_no_field_and_keeps_the_identity(fake):
    free = llm(fake, grammar="none")
    free.complete(make_prompt())
    assert not any(k in fake.requests[-1]["body"] for k in GRAMMAR_FIELDS)
    assert "grammar" not in json.loads(free.identity())
    on = json.loads(llm(fake, server="sglang").identity())
    assert (on["grammar"], on["server"]) == ("actions", "sglang")
    user = llm(fake, extra={"regex": "[0-9]"}, server="sglang")  # a field set in extra wins
    user.complete(make_prompt())
    assert fake.requests[-1]["body"]["regex"] == "[0-9]"
    with pytest.raises(ConfigError, match=r"^llm.server 'tgi' is unknown; available: vllm, sglang, llamacpp, none$"):
        llm(fake, server="tgi")
    with pytest.raises(ConfigError, match=r"^llm.grammar 'json' is unknown; allowed: none, actions$"):
        llm(fake, grammar="json")


def test_stop_at_action_list_cuts_the_reply_after_its_first_list_and_changes_the_identity(fake):
    fake.reply = "[[1, 2, 3, 4, 5, 6, 1]]\nand then [[7, 8, 9, 4, 5, 6, 0]]"
    whole, cut = llm(fake), llm(fake, stop_at_action_list=True)
    assert whole.complete(make_prompt()) == fake.reply  # X-ICM reads every list: the default
    assert cut.complete(make_prompt()) == "[[1, 2, 3, 4, 5, 6, 1]]"
    assert "stop_at_action_list" not in json.loads(whole.identity())  # cached replies stay valid
    assert json.loads(cut.identity())["stop_at_action_list"] is True
