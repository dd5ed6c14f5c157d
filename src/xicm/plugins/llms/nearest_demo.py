"""`nearest_demo`: an LLM-free baseline that replays the best demo re-anchored on the query's objects.

It answers with the same text an LLM would (`xicm.core.text.encoding.format_actions`, in the prompt's
action form: absolute, or anchored on `Prompt.anchors`), so its reply goes through the same parser
and executor as a model's.

``reply`` chooses what it answers with, for the demo at rank ``demo_rank`` of Prompt.demos
(default 0, the best one):

- ``reanchor`` (the baseline): the demo's actions moved onto the query's objects by the rule of
  `xicm.core.text.reanchor` (each action keeps its offset from its nearest demo object, which is mapped
  to the query object of the same name, else of the same index). Everything happens in metres;
  the text is quantised only at the end, like a demo's own text.
- ``copy``: the demo's action list exactly as the prompt writes it (absolute; or anchored on the
  demo's own listed objects, `Prompt.demo_anchors`), read back on the query's: what a model that
  copies the demo whole would answer. A yardstick for models' copies, not a method.

Fallbacks: a demo or query without objects gives the demo's actions unchanged; no demo at
all (or demo_rank beyond the list) gives ``[]``, which the parser reports as a parse error.

``grammar`` (none | actions) is accepted like the model LLMs' option (the paper presets set
``llm.grammar: none`` whichever LLM runs) and changes nothing: the reply is written by
``format_actions`` from the demo's own actions, so there is no free text to constrain.
``stop_at_action_list`` is accepted for the same reason and changes nothing (the reply is one list).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

from xicm.core.text.encoding import format_actions
from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.interfaces import LLM
from xicm.core.text.reanchor import reanchor
from xicm.core.contracts.schema import at_least, one_of
from xicm.core.contracts.types import Prompt
from xicm.plugins.llms.action_grammar import GRAMMARS, check_grammar

REPLIES = ("reanchor", "copy")


@dataclass
class NearestDemoOptions:
    demo_rank: int = field(default=0, metadata=at_least(0))  # 0: the best retrieved demo
    grammar: str = field(default="actions", metadata=one_of(*GRAMMARS))  # no effect (module docstring)
    reply: str = field(default="reanchor", metadata=one_of(*REPLIES))  # module docstring
    stop_at_action_list: bool = False  # no effect: the reply is one list (module docstring)


class NearestDemoLLM(LLM):
    """Replays the best retrieved demo re-anchored on the query objects; needs no model."""

    # Its reply depends on the exact object positions, not only on the prompt text (which
    # rounds them to 1 cm), so the message-keyed response cache must never answer for it.
    deterministic = False

    def __init__(self, options: NearestDemoOptions | None = None):
        o = options if options is not None else NearestDemoOptions()
        self.demo_rank = o.demo_rank
        self.reply = o.reply
        self.grammar = check_grammar(o.grammar)

    def complete(self, prompt: Prompt) -> str:
        if self.demo_rank >= len(prompt.demos):
            return "[]"
        demo = prompt.demos[self.demo_rank]
        if self.reply == "reanchor":
            return format_actions(reanchor(demo, prompt.query), prompt.workspace, prompt.anchors)  # in the prompt's form
        if prompt.anchors is None:
            return format_actions(demo.key_actions, prompt.workspace)
        if prompt.demo_anchors is None:
            raise ValueError("llm.reply=copy needs a prompt that says which objects its demos' anchored actions name (prompt=xicm_paper)")
        return format_actions(demo.key_actions, prompt.workspace, prompt.demo_anchors[self.demo_rank])

    def identity(self) -> str:
        extra = {} if self.reply == "reanchor" else {"reply": self.reply}  # the baseline's identity as before the option
        return json.dumps({"llm": "nearest_demo", "demo_rank": self.demo_rank, **extra}, sort_keys=True)


@hookimpl
def register_llms(register):
    register("nearest_demo", NearestDemoLLM, options=NearestDemoOptions)
