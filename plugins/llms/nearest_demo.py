"""`nearest_demo`: an LLM-free baseline that replays the best demo re-anchored on the query's objects.

It answers with the same text an LLM would (`xicm.core.encoding.format_actions`, in the prompt's
action form: absolute, or anchored on `Prompt.anchors`), so its reply goes through the same parser
and executor as a model's.

The rule, for the demo at rank ``demo_rank`` of Prompt.demos (default 0, the best one):

1. For each key action of the demo, the *anchor* is the demo object whose first-frame centre
   is nearest (Euclidean, metres) to the action's position.
2. The anchor is mapped to a query object: the query object with the same name when there is
   one; otherwise the query object at the anchor's index in the demo's object order (index
   taken modulo the number of query objects when the query has fewer objects).
3. The new action is placed at that query object's centre plus the action's offset from its
   anchor (``query_obj + (action - anchor)``); rotation and gripper state are copied.

Fallbacks: a demo or query without objects gives the demo's actions unchanged; no demo at
all (or demo_rank beyond the list) gives ``[]``, which the parser reports as a parse error.
Everything happens in metres; the text is quantised only at the end, like a demo's own text.

``grammar`` (none | actions) is accepted like the model LLMs' option (the paper presets set
``llm.grammar: none`` whichever LLM runs) and changes nothing: the reply is written by
``format_actions`` from the demo's own actions, so there is no free text to constrain.
``stop_at_action_list`` is accepted for the same reason and changes nothing (the reply is one list).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

from xicm.core.encoding import format_actions
from xicm.core.hookspecs import hookimpl
from xicm.core.interfaces import LLM
from xicm.core.schema import at_least, one_of
from xicm.plugins.llms.action_grammar import GRAMMARS, check_grammar
from xicm.core.types import Demo, KeyAction, Prompt, Query


def _nearest(objects: dict[str, tuple[float, float, float]], point) -> str:
    return min(objects, key=lambda name: math.dist(objects[name], point))


def map_object(name: str, demo: Demo, query: Query) -> str:
    """The query object that plays the role of demo object `name` (same name, else same index)."""
    if name in query.objects:
        return name
    demo_names = list(demo.objects)
    query_names = list(query.objects)
    return query_names[demo_names.index(name) % len(query_names)]


def reanchor(demo: Demo, query: Query) -> list[KeyAction]:
    """The demo's key actions moved onto the query's objects by the rule in the module docstring."""
    if not demo.objects or not query.objects:
        return list(demo.key_actions)
    actions = []
    for action in demo.key_actions:
        anchor = _nearest(demo.objects, action.position)
        target = query.objects[map_object(anchor, demo, query)]
        offset = [a - b for a, b in zip(action.position, demo.objects[anchor])]
        position = tuple(float(t + o) for t, o in zip(target, offset))
        actions.append(KeyAction(position=position, quat_wxyz=action.quat_wxyz, gripper_open=action.gripper_open))
    return actions


@dataclass
class NearestDemoOptions:
    demo_rank: int = field(default=0, metadata=at_least(0))  # 0: the best retrieved demo
    grammar: str = field(default="actions", metadata=one_of(*GRAMMARS))  # no effect (module docstring)
    stop_at_action_list: bool = False  # no effect: the reply is one list (module docstring)


class NearestDemoLLM(LLM):
    """Replays the best retrieved demo re-anchored on the query objects; needs no model."""

    # Its reply depends on the exact object positions, not only on the prompt text (which
    # rounds them to 1 cm), so the message-keyed response cache must never answer for it.
    deterministic = False

    def __init__(self, options: NearestDemoOptions | None = None):
        o = options if options is not None else NearestDemoOptions()
        self.demo_rank = o.demo_rank
        self.grammar = check_grammar(o.grammar)

    def complete(self, prompt: Prompt) -> str:
        if self.demo_rank >= len(prompt.demos):
            return "[]"
        demo = prompt.demos[self.demo_rank]
        return format_actions(reanchor(demo, prompt.query), prompt.workspace, prompt.anchors)  # in the prompt's form

    def identity(self) -> str:
        return json.dumps({"llm": "nearest_demo", "demo_rank": self.demo_rank}, sort_keys=True)


@hookimpl
def register_llms(register):
    register("nearest_demo", NearestDemoLLM, options=NearestDemoOptions)
