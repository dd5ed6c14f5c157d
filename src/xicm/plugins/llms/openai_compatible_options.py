"""The options of llm `openai_compatible` (documented in its module), checked before anything is built."""

from dataclasses import dataclass, field
from typing import Any, Dict, Optional

from xicm.core.contracts.schema import above, at_least, how, one_of, rule
from xicm.plugins.llms.action_grammar import GRAMMARS

SERVERS = ("vllm", "sglang", "llamacpp", "none")  # whose structured-output field carries the grammar


@dataclass
class OpenAICompatibleOptions:
    model: Optional[str] = None  # required: the LLM says so in one sentence
    base_url: str = "http://127.0.0.1:8000/v1"
    api_key_env: Optional[str] = field(default=None, metadata=how())
    mode: str = field(default="chat", metadata=one_of("chat", "completion"))
    completion_format: str = field(default="plain", metadata=one_of("plain", "raw"))
    # servers differ in their upper limits (OpenAI: temperature <= 2), so only the lower ones are checked
    temperature: Optional[float] = field(default=0.1, metadata=at_least(0))
    top_p: Optional[float] = field(default=0.001, metadata=rule(lambda v: 0 <= v <= 1, "a number from 0 to 1"))
    max_tokens: Optional[int] = field(default=256, metadata=at_least(1))
    extra: Optional[Dict[str, Any]] = None
    timeout_s: float = field(default=120.0, metadata=how(above(0)))
    retries: int = field(default=3, metadata=how(at_least(0)))
    grammar: str = field(default="actions", metadata=one_of(*GRAMMARS))
    server: str = field(default="vllm", metadata=one_of(*SERVERS))
    #: true: the reply is cut after its first action list (as transformers_local's option does);
    #: false: the whole reply, every later list included, as X-ICM reads it
    stop_at_action_list: bool = False
    #: with the grammar: lists of at most this many actions (null: the parser's 26)
    max_actions: Optional[int] = field(default=None, metadata=rule(lambda v: v is None or 1 <= v <= 26, "null or 1 to 26"))
