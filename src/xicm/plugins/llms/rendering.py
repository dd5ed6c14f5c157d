"""Turning chat messages into one prompt string for models or endpoints without a chat template.

`render_raw` (no role labels, contents joined by a blank line) is the other choice, for base
models that should simply continue the text.

The plain rendering is the fallback of `transformers_local` (a base model whose tokenizer has
no chat template) and the prompt of `openai_compatible` in ``mode: completion``::

    System: <system message>

    User: <user message>

    Assistant:

One block per message, role names capitalised (``System``, ``User``, ``Assistant``; any other
role is capitalised as it is), blocks separated by a blank line, and a final ``Assistant:``
with no trailing space so that the model continues right after it.
"""

from __future__ import annotations

from collections.abc import Sequence

_ROLE_NAMES = {"system": "System", "user": "User", "assistant": "Assistant"}


def render_plain(messages: Sequence[dict[str, str]]) -> str:
    """The messages as one 'System:/User:/Assistant:' transcript ending with 'Assistant:'."""
    blocks = []
    for message in messages:
        role = str(message.get("role", "user"))
        name = _ROLE_NAMES.get(role, role[:1].upper() + role[1:])
        blocks.append(f"{name}: {message.get('content', '')}")
    blocks.append("Assistant:")
    return "\n\n".join(blocks)


def fold_system(messages: Sequence[dict[str, str]]) -> list[dict[str, str]]:
    """Messages with the system messages merged into the first user message (for templates
    that reject the system role)."""
    system = [m["content"] for m in messages if m.get("role") == "system"]
    rest = [dict(m) for m in messages if m.get("role") != "system"]
    if not system:
        return rest
    prefix = "\n\n".join(system)
    for message in rest:
        if message.get("role") == "user":
            message["content"] = f"{prefix}\n\n{message.get('content', '')}"
            return rest
    return [{"role": "user", "content": prefix}, *rest]


def render_raw(messages: Sequence[dict[str, str]]) -> str:
    """The message contents joined by a blank line, no role labels (base-model continuation)."""
    return "\n\n".join(str(m.get("content", "")) for m in messages)
