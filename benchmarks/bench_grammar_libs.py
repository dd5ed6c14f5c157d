"""llguidance (the project's grammar library) against outlines-core on the action grammar
(`ACTIONS_REGEX`) with the embedded Gemma 3 270M tokenizer (262,144 tokens): one-time set-up,
per-step cost along real reply token sequences, agreement of the allowed-token sets at every
step, and the cost of the fast path's operations (forced tokens, draft check, rollback). Prints
figures; not a test.

outlines-core is not a project dependency; install it beside the venv and put it on the path:

    .venv/bin/python -m pip install --target /tmp/oc outlines-core
    PYTHONPATH=/tmp/oc:$PYTHONPATH .venv/bin/python benchmarks/bench_grammar_libs.py
    PYTHONPATH=/tmp/oc:$PYTHONPATH .venv/bin/python benchmarks/bench_grammar_libs.py --replies 8 --repeats 5

Replies: `" [[42, 53, 19, 0, 36, 36, 1], [42, 53, 19, 0, 36, 36, 0]]"` and --replies random
lists of 10-26 actions (seeded), written as `format_actions` writes them (half of them after the
optional leading space), tokenized with the model's tokenizer (the grammar is deterministic, so
a tokenized reply is a sequence both libraries must accept). At every position of every reply
each library computes the allowed set as a sorted id array (llguidance: `allowed_tokens`, the
function grammar_decode uses; outlines-core: `Guide.write_mask_into` unpacked the same way, and
`Guide.get_tokens`), the two sets are compared (as ids and as the texts they spell), and the
reply's next token is consumed. Also timed at every position: a draft of the next --draft reply
tokens checked, consumed and rolled back as grammar_decode does (llguidance `validate_tokens` /
`consume_tokens` / `rollback`; outlines-core has no prefix check, so `Index.get_next_state` is
walked, then `Guide.advance` / `rollback_state`), and counted: positions whose token llguidance's
`compute_ff_tokens` forces, and those where outlines-core's allowed tokens all spell one text (the
nearest it has to forced tokens).

Set-up rows: both libraries get the same token bytes (built once, timed once); the project's
`ActionMatcherFactory` is timed too (`llguidance.hf.from_tokenizer`, which reads tokenizer.json).

outlines-core's vocabulary is built from each token's bytes as its own `Vocabulary.from_pretrained`
does (SentencePiece's ``▁`` is a space, ``<0xNN>`` byte-fallback tokens are byte NN, special tokens
are left out, EOS is given separately); `Vocabulary.from_pretrained` itself needs the Hugging Face
hub, which an offline machine does not have.
"""

from __future__ import annotations

import argparse
import pickle
import random
import re
import statistics
import sys
import time
from pathlib import Path

import numpy as np

FIXED_REPLY = " [[42, 53, 19, 0, 36, 36, 1], [42, 53, 19, 0, 36, 36, 0]]"
OUTLINES_MISSING = (
    "outlines-core is not installed: run `python -m pip install --target /tmp/oc outlines-core` "
    "and put /tmp/oc first on PYTHONPATH."
)


def random_replies(n: int, seed: int) -> list[str]:
    """n action lists of 10-26 actions within the grammar's ranges, as format_actions writes them."""
    rng = random.Random(seed)
    replies = []
    for i in range(n):
        actions = [
            [rng.randint(0, 99) for _ in range(3)] + [rng.randint(0, 71) for _ in range(3)] + [rng.randint(0, 1)]
            for _ in range(rng.randint(10, 26))
        ]
        text = "[" + ", ".join("[" + ", ".join(map(str, a)) + "]" for a in actions) + "]"
        replies.append((" " if i % 2 == 0 else "") + text)
    return replies


def token_bytes(tokenizer, vocab_size: int) -> list[bytes | None]:
    """Each token id's bytes (None: a special token), as outlines-core's Vocabulary.from_pretrained
    reads a SentencePiece byte-fallback tokenizer: ``▁`` is a space, ``<0xNN>`` is byte NN."""
    byte_token = re.compile(r"<0x([0-9A-Fa-f]{2})>")
    special = set(tokenizer.all_special_ids)
    pieces = tokenizer.convert_ids_to_tokens(list(range(min(vocab_size, len(tokenizer)))))
    out: list[bytes | None] = [None] * vocab_size
    for token_id, piece in enumerate(pieces):
        if token_id in special or piece is None:
            continue
        match = byte_token.fullmatch(piece)
        out[token_id] = bytes([int(match.group(1), 16)]) if match else piece.replace("\u2581", " ").encode("utf-8")
    return out


def outlines_vocabulary(outlines_core, tokens: list[bytes | None], eos_id: int):
    by_bytes: dict[bytes, list[int]] = {}
    for token_id, data in enumerate(tokens):
        if data is not None and token_id != eos_id:
            by_bytes.setdefault(data, []).append(token_id)
    return outlines_core.Vocabulary(eos_id, by_bytes)


class _TokenBytes:
    """The same token bytes as llguidance's TokenizerWrapper reads them (special tokens empty)."""

    def __init__(self, tokenizer, tokens: list[bytes | None]):
        self._hf = tokenizer
        self.eos_token_id = tokenizer.eos_token_id
        self.bos_token_id = tokenizer.bos_token_id
        self.special_token_ids = list(tokenizer.all_special_ids)
        self.tokens = [b"" if data is None else data for data in tokens]

    def __call__(self, text: str) -> list[int]:
        return self._hf(text, add_special_tokens=False)["input_ids"]


def mask_to_ids(mask: np.ndarray, vocab_size: int) -> np.ndarray:
    """The set bits of a 32-bit token bitmask as sorted ids, as `allowed_tokens` unpacks it."""
    bits = np.unpackbits(mask.view(np.uint8), bitorder="little")[:vocab_size]
    return np.flatnonzero(bits)


def sparse_mask_to_ids(mask: np.ndarray) -> np.ndarray:
    """The same ids, unpacking only the non-zero 32-bit words (a grammar allows a few dozen tokens)."""
    words = np.flatnonzero(mask)
    bits = np.unpackbits(mask[words].view(np.uint8).reshape(-1, 4), axis=1, bitorder="little")
    rows, cols = np.nonzero(bits)
    return words[rows] * 32 + cols


def outlines_mask_ids(guide, mask: np.ndarray, vocab_size: int) -> np.ndarray:
    guide.write_mask_into(mask.ctypes.data, mask.size, 4)
    return mask_to_ids(mask, vocab_size)


def outlines_draft_prefix(index, state: int, draft: list[int]) -> int:
    """How many leading draft tokens the index accepts from state (llguidance's validate_tokens)."""
    for n, token in enumerate(draft):
        state = index.get_next_state(state, token)
        if state is None:
            return n
    return len(draft)


def describe_ids(ids, tokenizer) -> str:
    return ", ".join(f"{int(t)} {tokenizer.convert_ids_to_tokens(int(t))!r}" for t in ids[:6]) + (" ..." if len(ids) > 6 else "")


class Timer:
    """Per-operation lists of µs."""

    def __init__(self) -> None:
        self.us: dict[str, list[float]] = {}

    def __call__(self, name: str, fn, *args):
        t0 = time.perf_counter_ns()
        out = fn(*args)
        self.us.setdefault(name, []).append((time.perf_counter_ns() - t0) / 1000.0)
        return out

    def median(self, name: str) -> float:
        return statistics.median(self.us[name])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--replies", type=int, default=5, help="random 10-26-action replies besides the fixed one")
    parser.add_argument("--repeats", type=int, default=3, help="walks of every reply per library")
    parser.add_argument("--draft", type=int, default=8, help="draft length for the check/consume/rollback timing")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    if args.replies < 0 or args.repeats < 1 or not 1 <= args.draft <= 32:
        parser.error("--replies must be >= 0, --repeats >= 1 and --draft 1-32 (outlines-core keeps 32 states to roll back)")
    try:
        import outlines_core
    except ImportError:
        print(OUTLINES_MISSING)
        return 1
    import json
    from importlib.metadata import version

    import llguidance
    import llguidance.numpy as llg_numpy
    from transformers import AutoTokenizer
    from xicm.plugins.llms.action_grammar import ACTIONS_REGEX, ActionMatcherFactory, allowed_tokens
    from xicm.plugins.llms.model_files import embedded_model_dir

    folder = Path(embedded_model_dir())
    print(f"llguidance {version('llguidance')}, outlines-core {version('outlines-core')}; model folder {folder}")
    t0 = time.perf_counter()
    tokenizer = AutoTokenizer.from_pretrained(folder)
    load_s = time.perf_counter() - t0
    config = json.loads((folder / "config.json").read_text())
    vocab_size = int(config.get("vocab_size") or config.get("text_config", {}).get("vocab_size") or len(tokenizer))
    generation = json.loads((folder / "generation_config.json").read_text())
    eos = generation.get("eos_token_id", tokenizer.eos_token_id)
    eos_ids = [eos] if isinstance(eos, int) else list(eos)
    print(f"tokenizer: {len(tokenizer)} tokens, output layer {vocab_size} rows, EOS {eos_ids}; loaded in {load_s:.1f} s")

    # ---------------------------------------------------------------- one-time set-up (s)
    setup: dict[str, float] = {}
    t0 = time.perf_counter()
    factory = ActionMatcherFactory(tokenizer, vocab_size, eos_ids)
    setup["project_factory"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    tokens = token_bytes(tokenizer, vocab_size)
    setup["bytes"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    wrapper = llguidance.TokenizerWrapper(_TokenBytes(tokenizer, tokens))
    llg_tokenizer = llguidance.LLTokenizer(wrapper, n_vocab=vocab_size, eos_token=eos_ids)
    setup["llg_vocab"] = time.perf_counter() - t0
    grammar = llguidance.LLMatcher.grammar_from_regex(ACTIONS_REGEX)
    t0 = time.perf_counter()
    llguidance.LLMatcher(llg_tokenizer, grammar)
    setup["llg_compile"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    vocabulary = outlines_vocabulary(outlines_core, tokens, eos_ids[0])
    setup["oc_vocab"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    index = outlines_core.Index(ACTIONS_REGEX, vocabulary)
    setup["oc_compile"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    saved = pickle.dumps(index)
    setup["oc_save"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    pickle.loads(saved)
    setup["oc_load"] = time.perf_counter() - t0
    timer = Timer()
    for _ in range(5):
        timer("llg_new", factory.new)
        timer("oc_new", outlines_core.Guide, index)

    # ---------------------------------------------------------------- walks
    replies = [FIXED_REPLY, *random_replies(args.replies, args.seed)]
    sequences = [tokenizer(text, add_special_tokens=False)["input_ids"] for text in replies]
    for text, ids in zip(replies, sequences):
        assert tokenizer.decode(ids) == text, f"tokenizing {text[:40]!r} does not round-trip"
    bitmask = np.zeros((1, (vocab_size + 31) // 32), dtype=np.int32)
    oc_mask = np.zeros((vocab_size + 31) // 32, dtype=np.int32)
    per_reply: dict[str, list[float]] = {"llg": [], "oc_mask": [], "oc_list": []}
    steps = same_ids = same_bytes = text_diff_forced = only_byte_tokens = diff_unforced = 0
    first_diff: str | None = None
    first_text_diff: str | None = None
    forced = {"llg": 0, "oc": 0, "both": 0}
    ends = {"llg_stopped": 0, "llg_accepting": 0, "oc_finished": 0, "oc_eos_only": 0}
    for repeat in range(args.repeats):
        for text, ids in zip(replies, sequences):
            matcher, guide = factory.new(), outlines_core.Guide(index)
            walked = ("llg_allowed", "llg_advance", "oc_mask_ids", "oc_list_ids", "oc_advance")
            mark = {name: len(timer.us.get(name, [])) for name in walked}
            for pos in range(len(ids) + 1):  # the last position is after the closing "]]"
                llg_ids = timer("llg_allowed", allowed_tokens, matcher, vocab_size)
                timer("llg_fill", llg_numpy.fill_next_token_bitmask, matcher, bitmask, 0)
                timer("llg_sparse", sparse_mask_to_ids, bitmask[0])
                timer("oc_fill", guide.write_mask_into, oc_mask.ctypes.data, oc_mask.size, 4)
                oc_ids = timer("oc_mask_ids", outlines_mask_ids, guide, oc_mask, vocab_size)
                oc_list = timer("oc_list_ids", lambda: np.sort(np.asarray(guide.get_tokens(), dtype=np.int64)))
                if repeat == 0:
                    steps += 1
                    assert np.array_equal(oc_ids, oc_list) and np.array_equal(sparse_mask_to_ids(bitmask[0]), llg_ids)
                    llg_texts = {tokens[t] for t in llg_ids}
                    oc_texts = {tokens[t] for t in oc_ids}
                    same_ids += np.array_equal(llg_ids, oc_ids)
                    same_bytes += llg_texts == oc_texts
                    ff = bool(matcher.compute_ff_tokens())
                    text_diff_forced += llg_texts != oc_texts and ff and llg_texts < oc_texts
                    diff_unforced += not ff and not np.array_equal(llg_ids, oc_ids)
                    if first_text_diff is None and llg_texts != oc_texts:
                        show = lambda texts: sorted(t.decode("utf-8", "replace") for t in texts if t is not None)  # noqa: E731
                        first_text_diff = (
                            f"after {tokenizer.decode(ids[:pos])!r}: llguidance allows {show(llg_texts)}, "
                            f"outlines-core {show(oc_texts)}"
                        )
                    extra = np.setxor1d(llg_ids, oc_ids)
                    pieces = tokenizer.convert_ids_to_tokens([int(t) for t in extra])
                    only_byte_tokens += len(extra) > 0 and all(re.fullmatch(r"<0x[0-9A-F]{2}>", p) for p in pieces)
                    if first_diff is None and not np.array_equal(llg_ids, oc_ids):
                        only_llg, only_oc = np.setdiff1d(llg_ids, oc_ids), np.setdiff1d(oc_ids, llg_ids)
                        first_diff = (
                            f"after {tokenizer.decode(ids[:pos])!r}: llguidance allows {describe_ids(llg_ids, tokenizer)}; "
                            f"outlines-core also [{describe_ids(only_oc, tokenizer)}]"
                            + (f", llguidance also [{describe_ids(only_llg, tokenizer)}]" if len(only_llg) else "")
                        )
                    single_text = len({data for data in oc_texts if data is not None}) == 1 and eos_ids[0] not in oc_ids
                    forced["llg"] += ff
                    forced["oc"] += single_text
                    forced["both"] += ff and single_text
                if pos == len(ids):
                    if repeat == 0:
                        ends["llg_stopped"] += matcher.is_stopped()
                        ends["llg_accepting"] += matcher.is_accepting()
                        ends["oc_finished"] += guide.is_finished()
                        ends["oc_eos_only"] += list(oc_ids) == eos_ids[:1]
                    break
                draft = ids[pos : pos + args.draft]
                # the fast path's draft round: the grammar-valid prefix, consumed, then rolled back
                t0 = time.perf_counter_ns()
                n_llg = matcher.validate_tokens(draft)
                matcher.consume_tokens(draft[:n_llg])
                matcher.rollback(n_llg)
                timer.us.setdefault("llg_draft", []).append((time.perf_counter_ns() - t0) / 1000.0)
                t0 = time.perf_counter_ns()
                n_oc = outlines_draft_prefix(index, guide.get_state(), draft)
                for token in draft[:n_oc]:
                    guide.advance(token, return_tokens=False)
                guide.rollback_state(n_oc)
                timer.us.setdefault("oc_draft", []).append((time.perf_counter_ns() - t0) / 1000.0)
                assert n_llg == n_oc == len(draft), f"a draft of a valid reply was cut: llguidance {n_llg}, outlines-core {n_oc}"
                ok = timer("llg_advance", matcher.consume_token, ids[pos])
                assert ok, f"llguidance refused token {pos} of {text[:40]!r}: {matcher.get_error()}"
                timer("oc_advance", guide.advance, ids[pos], False)
            spent = {name: sum(timer.us[name][mark[name]:]) for name in mark}
            per_reply["llg"].append(spent["llg_allowed"] + spent["llg_advance"])
            per_reply["oc_mask"].append(spent["oc_mask_ids"] + spent["oc_advance"])
            per_reply["oc_list"].append(spent["oc_list_ids"] + spent["oc_advance"])

    # ---------------------------------------------------------------- report
    m = timer.median
    reply_ms = lambda name: statistics.median(per_reply[name]) / 1e3  # noqa: E731
    n_tokens = [len(ids) for ids in sequences]
    print(
        f"\nreplies: {len(replies)} ({min(n_tokens)}-{max(n_tokens)} tokens, {sum(n_tokens)} in all), "
        f"walked {args.repeats} times each"
    )
    print(f"outlines-core index: {len(index.get_transitions())} states\n")
    rows = [
        ("set-up (s)", None, None, ""),
        ("token bytes from the tokenizer (Python)", setup["bytes"], setup["bytes"], "the same list for both"),
        ("tokenizer/vocabulary object from the bytes", setup["llg_vocab"], setup["oc_vocab"], ""),
        ("ActionMatcherFactory (as the project runs it)", setup["project_factory"], None, "llguidance.hf.from_tokenizer"),
        ("regex compile: first matcher / Index", setup["llg_compile"], setup["oc_compile"], ""),
        ("Index to bytes (pickle, for a disk cache; ms)", None, setup["oc_save"] * 1e3, f"{len(saved) / 1e6:.2f} MB"),
        ("Index from those bytes (ms)", None, setup["oc_load"] * 1e3, ""),
        ("per reply and per step (µs, medians)", None, None, ""),
        ("new matcher / Guide", m("llg_new"), m("oc_new"), ""),
        ("allowed ids: mask + unpack (allowed_tokens)", m("llg_allowed"), m("oc_mask_ids"), ""),
        ("   of which filling the bitmask", m("llg_fill"), m("oc_fill"), ""),
        ("allowed ids: fill + unpack non-zero words only", m("llg_fill") + m("llg_sparse"), None, "this bench's unpack"),
        ("allowed ids: Guide.get_tokens, sorted", None, m("oc_list_ids"), "no mask"),
        ("advance by one token", m("llg_advance"), m("oc_advance"), ""),
        ("step: allowed_tokens + advance", m("llg_allowed") + m("llg_advance"), m("oc_mask_ids") + m("oc_advance"), ""),
        ("step: cheapest ids + advance", m("llg_fill") + m("llg_sparse") + m("llg_advance"), m("oc_list_ids") + m("oc_advance"), ""),
        ("per reply, allowed_tokens path (ms)", reply_ms("llg"), reply_ms("oc_mask"), ""),
        ("per reply, get_tokens path (ms)", None, reply_ms("oc_list"), ""),
        (f"draft of {args.draft}: check + consume + rollback", m("llg_draft"), m("oc_draft"), "outlines-core: emulated"),
    ]
    print(f"{'':48s} {'llguidance':>12s} {'outlines-core':>14s}")
    for label, llg, oc, note in rows:
        cell = lambda v: f"{'':>12s}" if v is None else f"{v:12.3f}" if v < 10 else f"{v:12.1f}"  # noqa: E731
        print(f"{label:48s} {cell(llg)} {cell(oc):>14s}   {note}".rstrip() if llg is not None or oc is not None else label)
    print(
        f"\npositions whose token is forced: llguidance compute_ff_tokens {forced['llg']}, outlines-core one allowed "
        f"text (emulated) {forced['oc']}, both {forced['both']}, of {steps}"
    )
    print(
        f"agreement over {steps} positions: identical id sets {same_ids}, identical sets of allowed texts {same_bytes}; "
        f"different texts where llguidance forces tokens and allows a subset of outlines-core's: {text_diff_forced}; "
        f"different ids that are byte-fallback tokens <0xNN> only: {only_byte_tokens}; "
        f"different ids where llguidance forces nothing: {diff_unforced}"
    )
    if first_diff:
        print(f"first difference of ids {first_diff}")
    if first_text_diff:
        print(f"first difference of texts {first_text_diff}")
    print(
        f"after the closing ']]' ({len(replies)} replies): llguidance stopped {ends['llg_stopped']}, accepting "
        f"{ends['llg_accepting']}; outlines-core finished {ends['oc_finished']}, allows only EOS {ends['oc_eos_only']}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
