"""The options of llm `llamacpp` (documented in llamacpp.py), checked before anything is built."""

from dataclasses import dataclass, field
from typing import List, Optional

from xicm.core.contracts.schema import above, at_least, how, one_of, rule
from xicm.plugins.llms.action_grammar import GRAMMARS

CHAT_TEMPLATES = ("model", "plain", "raw")


@dataclass
class LlamaCppOptions:
    model: Optional[str] = None  # required: a catalogued name or a .gguf path
    binary: Optional[str] = None
    threads: int = field(default=2, metadata=how(at_least(1)))
    parallel: int = field(default=1, metadata=how(at_least(1)))  # server slots: requests decoded in one batch
    ctx_size: int = field(default=8192, metadata=at_least(256))
    chat_template: str = field(default="model", metadata=one_of(*CHAT_TEMPLATES))
    temperature: float = field(default=0.0, metadata=at_least(0))
    top_p: float = field(default=1.0, metadata=rule(lambda v: 0 <= v <= 1, "a number from 0 to 1"))
    top_k: int = field(default=40, metadata=at_least(0))
    repeat_penalty: float = field(default=1.0, metadata=above(0))
    repeat_last_n: int = field(default=64, metadata=at_least(-1))
    dry_multiplier: float = field(default=0.0, metadata=at_least(0))  # 0: DRY off (the paper has none)
    dry_base: float = field(default=1.75, metadata=at_least(1))
    dry_allowed_length: int = field(default=2, metadata=at_least(0))
    dry_penalty_last_n: int = field(default=-1, metadata=at_least(-1))
    max_tokens: int = field(default=256, metadata=at_least(1))
    seed: int = field(default=0, metadata=at_least(0))
    stop: Optional[List[str]] = None
    grammar: str = field(default="actions", metadata=one_of(*GRAMMARS))
    stop_at_action_list: bool = False  # true: the reply is cut after its first action list
    max_actions: Optional[int] = field(default=None, metadata=rule(lambda v: v is None or 1 <= v <= 26, "null or 1 to 26"))
    cache_dir: Optional[str] = field(default=None, metadata=how())
    find_links: Optional[str] = field(default=None, metadata=how())
    startup_timeout_s: float = field(default=120.0, metadata=how(above(0)))
    timeout_s: float = field(default=900.0, metadata=how(above(0)))
    server_args: Optional[List[str]] = None
    repack: bool = field(default=False, metadata=how())
    speculative: str = field(default="ngram-mod", metadata=how(one_of("none", "ngram-simple", "ngram-mod")))
    draft_max: int = field(default=16, metadata=how(at_least(1)))  # the most tokens one draft guesses
    draft_min: int = field(default=48, metadata=how(at_least(0)))  # ngram-mod: shorter drafts are not tried
    draft_lookup: int = field(default=24, metadata=how(at_least(1)))  # tokens matched to find a draft
