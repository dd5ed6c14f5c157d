"""The llama.cpp engine (llm `llamacpp`) on a real llama-server and a tiny GGUF written by the
`gguf` package (tests/tiny_gguf.py): the action grammar, the chat template, prefix reuse,
repeatable replies, the prompt that does not fit, and the server's lifecycle (stop, and a
SIGKILLed owner). The llama-server is the cached build: tests/prebuild.py starts it beside the
suite when it is missing, and these tests, marked `llama_server`, run last and wait for it."""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tiny_gguf import write_tiny_gguf
from xicm.core.contracts.errors import ConfigError, LLMError
from xicm.core.text.parsing import parse_actions
from xicm.core.contracts.schema import check_options
from xicm.plugins.llms import llamacpp_server
from xicm.plugins.llms.action_grammar import ACTIONS_REGEX, ANCHORED_REGEX, reply_regex
from xicm.plugins.llms.llamacpp import LlamaCppLLM, draft_flags
from xicm.plugins.llms.llamacpp_options import LlamaCppOptions

pytestmark = pytest.mark.llama_server

WS = ((-0.3, -0.5, 0.6), (0.7, 0.5, 1.6))
DEMOS = "".join(f"['instruction': task {i}, {{'cube': [{i}, 2, 3]}}]>[[{i}, 2, 3, 4, 5, 6, 1]], " for i in range(30))


@pytest.fixture(scope="session")
def server_binary() -> Path:
    return llamacpp_server.llama_server_binary()  # waits on the build's lock while tests/prebuild.py builds it


@pytest.fixture(scope="session")
def tiny_model(tmp_path_factory) -> Path:
    return write_tiny_gguf(tmp_path_factory.mktemp("gguf") / "tiny.gguf")


@pytest.fixture
def make_llm(server_binary, tiny_model):
    made = []

    def make(**options):
        llm = LlamaCppLLM(LlamaCppOptions(**{"model": str(tiny_model), "binary": str(server_binary), "threads": 1,
                             "ctx_size": 4096, "chat_template": "raw", "max_tokens": 800, **options}))
        made.append(llm)
        return llm

    yield make
    for llm in made:
        llm.stop()


def messages(query: str) -> list[dict[str, str]]:
    return [{"role": "user", "content": DEMOS + query}]


def listening(port: int) -> bool:
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) == 0


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f"/proc/{pid}/stat") as f:  # a zombie has exited
        return f.read().split(")")[-1].split()[0] != "Z"


def test_the_grammar_holds_replies_to_the_action_list(make_llm):
    free, constrained = make_llm(grammar="none"), make_llm(grammar="actions")
    query = "['instruction': lift it, {'cube': [9, 9, 9]}]>"
    reply = constrained.complete_messages(messages(query))
    assert re.fullmatch(ACTIONS_REGEX, reply), reply
    assert len(parse_actions(reply, WS)) >= 1
    assert not re.fullmatch(ACTIONS_REGEX, free.complete_messages(messages(query)))  # random weights: noise


def test_max_actions_ends_the_list_there(make_llm):
    """The tiny model's greedy reply to this query is a list of three actions; llm.max_actions=2
    lets the grammar close the list after two, in fewer decoded tokens."""
    query = messages(">[[")
    free, bounded = make_llm(), make_llm(max_actions=2)
    long = free.complete_messages(query)
    short = bounded.complete_messages(query)
    assert len(parse_actions(long, WS)) > 2, long
    assert re.fullmatch(reply_regex(False, 2), short), short
    assert parse_actions(short, WS) == parse_actions(long, WS)[:2]  # greedy: the same first two
    assert bounded.last_call["predicted_n"] < free.last_call["predicted_n"]
    assert '"max_actions": 2' in bounded.identity() and "max_actions" not in free.identity()


def test_a_prompt_with_anchored_actions_gets_the_anchored_grammar(make_llm):
    constrained = make_llm(grammar="actions")
    query = "['instruction': lift it, {'cube': [9, 9, 9]}]>"
    reply = constrained.complete_messages(messages(query), anchored=True)
    assert re.fullmatch(ANCHORED_REGEX, reply), reply
    assert not re.fullmatch(ACTIONS_REGEX, reply)


def test_the_model_chat_template_is_applied(make_llm):
    raw, chat = make_llm(max_tokens=4, grammar="none"), make_llm(max_tokens=4, grammar="none", chat_template="model")
    raw.complete_messages([{"role": "user", "content": "abc"}])
    chat.complete_messages([{"role": "user", "content": "abc"}])
    # tiny_gguf's template writes "user: abc\nassistant:" around the content: 16 more characters
    assert chat.last_call["prompt_tokens"] - raw.last_call["prompt_tokens"] == len("user: \nassistant:")


def test_the_shared_prefix_is_reused_and_replies_repeat(make_llm):
    llm = make_llm()
    first = [llm.complete_messages(messages(f"['instruction': go {i}, {{'cube': [{i}, 1, 1]}}]>")) for i in range(3)]
    assert llm.last_call["cache_n"] >= len(DEMOS) - 5  # only the query was prefilled again
    assert llm.last_call["prompt_n"] < 40
    pid = llm._server.process.pid
    llm.stop()
    again = make_llm()  # a new server, a cold cache: the same replies
    assert [again.complete_messages(messages(f"['instruction': go {i}, {{'cube': [{i}, 1, 1]}}]>")) for i in range(3)] == first
    assert again._server.process.pid != pid


def test_llms_of_one_process_share_one_server_started_from_any_thread(make_llm):
    import threading

    llms, replies = [make_llm(max_tokens=8), make_llm(max_tokens=8)], []
    threads = [threading.Thread(target=lambda llm=llm: replies.append(llm.complete_messages(messages(">")))) for llm in llms]
    for thread in threads:  # like envs=N: each slot thread makes its policy's first call, then ends
        thread.start()
        thread.join()
    assert llms[0]._server is llms[1]._server and llms[0]._server.running()
    assert replies[0] == replies[1]


def test_two_slots_decode_two_requests_at_once(make_llm):
    """llm.parallel=2: two requests released together are in flight together (each started before
    the other ended; both prefill the cold demos first), and the slot that served a prompt keeps
    its prefix for the next one."""
    import json
    import threading
    import urllib.request

    queries = [f"['instruction': go {i}, {{'cube': [{i}, 1, 1]}}]>" for i in range(2)]
    llms = [make_llm(parallel=2, speculative="none", grammar="none") for _ in queries]
    assert llms[0].concurrent_requests == 2
    for llm in llms:
        llm.start()
    assert llms[0]._server is llms[1]._server
    props = json.loads(urllib.request.urlopen(llms[0]._server.base_url + "/props", timeout=10).read())
    assert props["total_slots"] == 2
    spans: dict[int, tuple[float, float]] = {}
    together = threading.Barrier(2)

    def ask(i: int) -> None:
        together.wait()
        t0 = time.perf_counter()
        llms[i].complete_messages(messages(queries[i]))
        spans[i] = (t0, time.perf_counter())

    threads = [threading.Thread(target=ask, args=(i,)) for i in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert sorted(spans) == [0, 1], "a request failed"
    (start0, end0), (start1, end1) = spans[0], spans[1]
    assert start1 < end0 and start0 < end1  # in flight together
    assert all(llm.last_call["predicted_n"] > 0 for llm in llms), [llm.last_call for llm in llms]
    llms[0].complete_messages(messages(queries[0]))  # the slot that served it still holds its prefix
    assert llms[0].last_call["cache_n"] >= len(DEMOS) - 5


def test_speculative_decoding_leaves_the_replies_as_they_are(make_llm):
    queries = [f"['instruction': go {i}, {{'cube': [{i}, 1, 1]}}]>" for i in range(3)]
    plain, drafted = make_llm(speculative="none"), make_llm(speculative="ngram-mod")
    assert [drafted.complete_messages(messages(q)) for q in queries] == [plain.complete_messages(messages(q)) for q in queries]
    assert plain._server is not drafted._server and "--spec-type" in drafted._server.argv(0)


def test_the_draft_sizes_reach_the_server_and_drafts_are_tried(make_llm):
    query = messages(DEMOS[: len(DEMOS) // 3] + "['instruction': task 3, {'cube': [3, 2, 3]}]>")
    plain = make_llm(speculative="none", max_tokens=120)
    drafted = make_llm(speculative="ngram-mod", draft_max=8, draft_min=1, draft_lookup=2, max_tokens=120)
    assert drafted.complete_messages(query) == plain.complete_messages(query)
    assert drafted.last_call.get("draft_n", 0) > 0, drafted.last_call  # llama.cpp's sizes (n_min 48) try none here
    argv = drafted._server.argv(0)
    flags = {flag: argv[argv.index(flag) + 1] for flag in ("--spec-ngram-mod-n-max", "--spec-ngram-mod-n-min", "--spec-ngram-mod-n-match")}
    assert flags == {"--spec-ngram-mod-n-max": "8", "--spec-ngram-mod-n-min": "1", "--spec-ngram-mod-n-match": "2"}
    simple = LlamaCppOptions(model="m", speculative="ngram-simple", draft_max=8, draft_lookup=2)
    assert draft_flags(simple) == ["--spec-ngram-simple-size-m", "8", "--spec-ngram-simple-size-n", "2"]


def test_the_dry_sampler_reaches_the_server(make_llm):
    query = messages("['instruction': go, {'cube': [9, 9, 9]}]>")
    plain = make_llm(max_tokens=60).complete_messages(query)
    dry = make_llm(max_tokens=60, dry_multiplier=5.0, dry_base=2.0, dry_allowed_length=1).complete_messages(query)
    assert dry.lstrip().startswith("[[") and plain.lstrip().startswith("[["), (plain, dry)
    assert dry != plain  # the same greedy decoding, but tokens that repeat the context lose logits


def test_stop_ends_the_server_and_frees_its_port(make_llm):
    llm = make_llm(max_tokens=8)
    llm.complete_messages(messages(">"))
    process, port = llm._server.process, llm._server.port
    assert listening(port)
    llm.stop()
    assert process.poll() is not None and not listening(port)
    llm.complete_messages(messages(">"))  # the next call starts another
    assert llm._server.running()


def test_a_sigkilled_owner_leaves_no_server_and_no_port(server_binary, tiny_model):
    code = (
        "import sys, time\n"
        "from xicm.plugins.llms.llamacpp import LlamaCppLLM, LlamaCppOptions\n"
        f"llm = LlamaCppLLM(LlamaCppOptions(model={str(tiny_model)!r}, binary={str(server_binary)!r}, threads=1, ctx_size=512, chat_template='raw'))\n"
        "llm.start()\n"
        "print(llm._server.process.pid, llm._server.port, flush=True)\n"
        "time.sleep(120)\n"
    )
    owner = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        pid, port = map(int, owner.stdout.readline().split())
        assert alive(pid) and listening(port)
        owner.send_signal(signal.SIGKILL)
        owner.wait(timeout=10)
        deadline = time.monotonic() + 10
        while (alive(pid) or listening(port)) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not alive(pid) and not listening(port)
    finally:
        owner.kill()


def test_a_prompt_that_does_not_fit_is_one_sentence(make_llm):
    llm = make_llm(ctx_size=256)
    with pytest.raises(LLMError, match=r"^the prompt does not fit llm.ctx_size=256 of tiny.gguf: it and max_tokens=800 need \d+ tokens; raise llm.ctx_size or use fewer demos \(policy.k\)$"):
        llm.complete_messages(messages(">"))


def test_a_missing_binary_or_model_is_one_sentence(tmp_path, monkeypatch, tiny_model):
    with pytest.raises(ConfigError, match="llm.binary /nonexistent/llama-server is not an executable file"):
        LlamaCppLLM(LlamaCppOptions(model=str(tiny_model), binary="/nonexistent/llama-server")).start()
    with pytest.raises(ConfigError, match="llm.model 'nope.gguf' is neither a catalogued model"):
        LlamaCppLLM(LlamaCppOptions(model="nope.gguf")).start()
    monkeypatch.setenv("XICM_CACHE", str(tmp_path))
    monkeypatch.setattr(llamacpp_server.shutil, "which", lambda tool: None if tool == "cmake" else "/usr/bin/" + tool)
    with pytest.raises(ConfigError, match=r"building llama-server needs cmake, not found; install them \(Debian: apt-get install -y cmake"):
        LlamaCppLLM(LlamaCppOptions(model=str(tiny_model))).start()


def test_a_server_that_died_between_calls_is_started_again(make_llm, capsys):
    llm = make_llm(max_tokens=8)
    reply = llm.complete_messages(messages(">"))
    pid = llm._server.process.pid
    llm._server.process.kill()
    llm._server.process.wait()
    assert llm.complete_messages(messages(">")) == reply
    assert llm._server.process.pid != pid
    assert "llama-server exited" in capsys.readouterr().err


def test_identity_names_model_and_decoding():
    llm = LlamaCppLLM(LlamaCppOptions(model="qwen2_5_coder_0_5b", temperature=0.1, top_p=0.001, repeat_penalty=1.05, repeat_last_n=-1))
    identity = llm.identity()
    for part in ('"model": "qwen2_5_coder_0_5b"', '"repeat_last_n": -1', '"grammar": "actions"', '"seed": 0'):
        assert part in identity
    assert llm.deterministic


def test_dry_is_in_the_identity_and_the_request_only_when_it_is_on():
    off = LlamaCppLLM(LlamaCppOptions(model="qwen2_5_coder_0_5b", ctx_size=4096))
    on = LlamaCppLLM(LlamaCppOptions(model="qwen2_5_coder_0_5b", ctx_size=4096, dry_multiplier=0.8, dry_allowed_length=12))
    assert "dry" not in off.identity() and not any(k.startswith("dry") for k in off._request)  # cached replies stay valid
    assert '"dry_multiplier": 0.8' in on.identity() and '"dry_allowed_length": 12' in on.identity()
    assert on._request["dry_penalty_last_n"] == 4096  # -1 (the whole context) in the server's terms
    with pytest.raises(ConfigError, match="llm.dry_base"):
        check_options({"model": "x", "dry_base": 0.5}, LlamaCppOptions, "llm", "llm 'llamacpp'")


def test_stop_at_action_list_is_in_the_identity_only_when_it_cuts():
    whole = LlamaCppLLM(LlamaCppOptions(model="qwen2_5_coder_0_5b"))
    cut = LlamaCppLLM(LlamaCppOptions(model="qwen2_5_coder_0_5b", stop_at_action_list=True))
    assert "stop_at_action_list" not in whole.identity()  # replies cached before the option stay valid
    assert '"stop_at_action_list": true' in cut.identity() and cut.stop_at_action_list


def test_another_llama_server_build_caches_its_replies_apart(tmp_path):
    default = LlamaCppLLM(LlamaCppOptions(model="qwen2_5_coder_0_5b"))
    builds = []
    for body in (b"#!/bin/sh\necho one\n", b"#!/bin/sh\necho two\n"):
        binary = tmp_path / f"llama-server-{len(builds)}"
        binary.write_bytes(body)
        binary.chmod(0o755)
        builds.append(LlamaCppLLM(LlamaCppOptions(model="qwen2_5_coder_0_5b", binary=str(binary))))
    assert "binary" not in default.identity()  # replies cached with the default build stay valid
    assert len({default.identity(), *(b.identity() for b in builds)}) == 3
    missing = LlamaCppLLM(LlamaCppOptions(model="qwen2_5_coder_0_5b", binary=str(tmp_path / "absent")))
    with pytest.raises(ConfigError, match="llm.binary .* is not an executable file"):
        missing.identity()


def test_another_pinned_llama_cpp_version_caches_its_replies_apart(monkeypatch):
    options = LlamaCppOptions(model="qwen2_5_coder_0_5b")
    first = LlamaCppLLM(options).identity()
    assert "llama_cpp" not in first  # replies cached under the first pinned build stay valid
    monkeypatch.setattr(llamacpp_server, "LLAMACPP_VERSION", "99999")
    bumped = LlamaCppLLM(options).identity()
    assert bumped != first and '"llama_cpp": "99999"' in bumped


def test_the_build_script_builds_the_version_the_plugin_runs():
    script = llamacpp_server.BUILD_SCRIPT.read_text()
    assert re.search(r'^VERSION="\$\{VERSION:-(\d+)\}"$', script, re.M).group(1) == llamacpp_server.LLAMACPP_VERSION
    assert re.search(r'^\[ "\$VERSION" = (\d+) \] \|\| PINNED_SHA256=""$', script, re.M).group(1) == llamacpp_server.LLAMACPP_VERSION
