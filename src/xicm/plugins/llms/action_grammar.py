"""The grammar of an X-ICM reply (``llm.grammar: actions``), in the forms decoders and servers take.

A reply is one list of 1 to 26 actions, each ``[x, y, z, roll, pitch, yaw, gripper]``: x/y/z
0-99, rotations 0-71, gripper 0/1, integers without leading zeros, written exactly as the
prompt's demos are (`xicm.core.text.encoding.format_actions`: ``", "`` between items and between
actions, no other whitespace), optionally after one space (a base model continuing the query's
``>`` writes `` [[``). Every such text parses (`xicm.core.text.parsing.parse_actions`) to all of its
actions, and nothing else can be generated.

`ACTIONS_REGEX` is the form llguidance (in-process), vLLM and SGLang take; `ACTIONS_GBNF` the
llama.cpp server's. Both are built here from the same pieces and tested against each other.

A prompt that writes anchored actions (`prompt.actions: anchored`, `Prompt.anchors`) gets replies of
``[object, dx, dy, dz, roll, pitch, yaw, gripper]`` instead: object 0-9, offsets -99 to 99, the
rest as above (`ANCHORED_REGEX`, `ANCHORED_GBNF`; `reply_regex` / `reply_gbnf` pick by prompt).
"""

from __future__ import annotations

from xicm.core.text.parsing import MAX_ACTIONS

GRAMMARS = ("none", "actions")

_POSITION = "(?:[0-9]|[1-9][0-9])"  # 0-99
_ROTATION = "(?:[0-9]|[1-6][0-9]|7[01])"  # 0-71
_GRIPPER = "[01]"
_OBJECT = "[0-9]"
_OFFSET = "-?" + _POSITION  # -99 to 99
_ACTION = r"\[" + ", ".join([_POSITION] * 3 + [_ROTATION] * 3 + [_GRIPPER]) + r"\]"
_ANCHORED = r"\[" + ", ".join([_OBJECT] + [_OFFSET] * 3 + [_ROTATION] * 3 + [_GRIPPER]) + r"\]"


def _list_regex(action: str, max_actions: int = MAX_ACTIONS) -> str:
    return r" ?\[" + action + r"(?:, " + action + "){0," + str(max_actions - 1) + r"}\]"


#: the reply as a regular expression (Python / Rust regex syntax, no anchors: the whole reply matches)
ACTIONS_REGEX = _list_regex(_ACTION)
ANCHORED_REGEX = _list_regex(_ANCHORED)

def _root_gbnf(max_actions: int) -> str:
    return f'root ::= " "? "[" action (", " action){{0,{max_actions - 1}}} "]"'


#: the same language in llama.cpp's GBNF (grammars/README.md of llama.cpp)
ACTIONS_GBNF = "\n".join(
    [
        _root_gbnf(MAX_ACTIONS),
        'action ::= "[" pos ", " pos ", " pos ", " rot ", " rot ", " rot ", " grip "]"',
        "pos ::= [0-9] | [1-9] [0-9]",
        "rot ::= [0-9] | [1-6] [0-9] | \"7\" [01]",
        "grip ::= [01]",
    ]
)
ANCHORED_GBNF = "\n".join(
    [
        _root_gbnf(MAX_ACTIONS),
        'action ::= "[" obj ", " off ", " off ", " off ", " rot ", " rot ", " rot ", " grip "]"',
        "obj ::= [0-9]",
        'off ::= "-"? pos',
        "pos ::= [0-9] | [1-9] [0-9]",
        "rot ::= [0-9] | [1-6] [0-9] | \"7\" [01]",
        "grip ::= [01]",
    ]
)


def reply_regex(anchored: bool, max_actions: int | None = None) -> str:
    """The reply's regex for a prompt with absolute (False) or anchored (True) actions, lists of
    at most `max_actions` actions (None: the parser's MAX_ACTIONS)."""
    if max_actions is None or max_actions == MAX_ACTIONS:
        return ANCHORED_REGEX if anchored else ACTIONS_REGEX
    return _list_regex(_ANCHORED if anchored else _ACTION, _check_max(max_actions))


def reply_gbnf(anchored: bool, max_actions: int | None = None) -> str:
    """The reply's GBNF for a prompt with absolute (False) or anchored (True) actions, lists of
    at most `max_actions` actions (None: the parser's MAX_ACTIONS): the grammar then allows only
    the list's end after the last one, so a reply that would repeat on stops there."""
    grammar = ANCHORED_GBNF if anchored else ACTIONS_GBNF
    if max_actions is None or max_actions == MAX_ACTIONS:
        return grammar
    return grammar.replace(_root_gbnf(MAX_ACTIONS), _root_gbnf(_check_max(max_actions)), 1)


def _check_max(max_actions: int) -> int:
    if not 1 <= int(max_actions) <= MAX_ACTIONS:
        raise ValueError(f"max_actions must be 1 to {MAX_ACTIONS}, not {max_actions}")
    return int(max_actions)


def check_grammar(value: str) -> str:
    """The grammar name, or a ConfigError sentence naming the allowed ones."""
    from xicm.core.contracts.errors import ConfigError

    if value not in GRAMMARS:
        raise ConfigError(f"llm.grammar '{value}' is unknown; allowed: {', '.join(GRAMMARS)}")
    return value


class ActionMatcherFactory:
    """llguidance matchers of `ACTIONS_REGEX` for one tokenizer (the tokenizer is converted once)."""

    def __init__(self, hf_tokenizer, vocab_size: int, eos_token_ids: list[int]):
        import llguidance
        import llguidance.hf

        self.vocab_size = int(vocab_size)
        eos = eos_token_ids or None
        try:
            self._tokenizer = llguidance.hf.from_tokenizer(hf_tokenizer, n_vocab=self.vocab_size, eos_token=eos)
        except ValueError:  # a tokenizers.json llguidance cannot read (e.g. a Fuse decoder): token texts
            wrapper = llguidance.TokenizerWrapper(_TokenTexts(hf_tokenizer, self.vocab_size))
            self._tokenizer = llguidance.LLTokenizer(wrapper, n_vocab=self.vocab_size, eos_token=eos)
        self._grammar = llguidance.LLMatcher.grammar_from_regex(ACTIONS_REGEX)

    def new(self):
        """A fresh matcher at the start of a reply."""
        import llguidance

        matcher = llguidance.LLMatcher(self._tokenizer, self._grammar)
        if matcher.is_error():
            raise RuntimeError(f"llguidance rejected the action grammar: {matcher.get_error()}")
        return matcher


class _TokenTexts:
    """A tokenizer as llguidance's TokenizerWrapper reads it: each token's bytes are its decoded
    text (exact for tokenizers whose tokens are whole characters)."""

    def __init__(self, hf_tokenizer, vocab_size: int):
        self._hf = hf_tokenizer
        self.eos_token_id = hf_tokenizer.eos_token_id
        self.bos_token_id = hf_tokenizer.bos_token_id
        self.special_token_ids = list(hf_tokenizer.all_special_ids)
        special = set(self.special_token_ids)
        self.tokens = [
            b"" if i in special or i >= len(hf_tokenizer) else hf_tokenizer.decode([i]).encode("utf-8")
            for i in range(vocab_size)
        ]

    def __call__(self, text: str) -> list[int]:
        return self._hf(text, add_special_tokens=False)["input_ids"]


def allowed_tokens(matcher, vocab_size: int):
    """Token ids the matcher allows next (a sorted int64 numpy array)."""
    import llguidance.numpy as llg_numpy
    import numpy as np

    mask = llg_numpy.allocate_token_bitmask(1, vocab_size)
    llg_numpy.fill_next_token_bitmask(matcher, mask, 0)
    words = np.flatnonzero(mask[0])  # a few dozen of the 8,192 32-bit words: unpack only those
    bits = np.unpackbits(mask[0][words].view(np.uint8).reshape(len(words), 4), axis=1, bitorder="little")
    rows, cols = np.nonzero(bits)
    ids = words[rows] * 32 + cols
    return ids[ids < vocab_size].astype(np.int64)
