"""Prompt builder "xicm": the X-ICM in-context prompt.

A system message describes the robot and the action text; one user message then holds one
line per demonstration, best first,

    {instruction}. Objects: {name [x, y, z], ...} > [[x, y, z, roll, pitch, yaw, open], ...]

and last the query line, which ends with '>' for the model to continue. Integers come from
xicm.core.text.encoding (100^3 workspace voxels, 72 rotation bins of 5 degrees, gripper 1/0).
How many demos to show is the agent's choice, not the builder's.

Options:
    system_prompt: replaces the default system message (a string; may be empty to send none).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from xicm.core.text import encoding
from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.interfaces import Box, PromptBuilder
from xicm.core.contracts.types import Demo, Prompt, Query

SYSTEM_PROMPT = (
    "You control a Franka Panda robot arm that has a parallel-jaw gripper. "
    "You will see examples of tabletop tasks, one per line, each written as "
    '"<instruction>. Objects: <objects> > <action list>". '
    "<objects> gives each relevant object's name followed by the [x, y, z] voxel of its centre, "
    "or by 'not detected' when the robot could not find it. "
    "The action list is the sequence of key poses the gripper moved through; every action is a "
    "list of 7 integers [x, y, z, roll, pitch, yaw, gripper_open]. "
    "x, y and z are voxel indices (0 to 99) on a 100x100x100 grid laid over the workspace. "
    "roll, pitch and yaw are rotation angles split into 72 bins of 5 degrees each (0 to 71). "
    "gripper_open is 1 when the gripper is open and 0 when it is closed. "
    "The last line is a new task that ends with '>'. Answer with the action list for that new task "
    "only, following the trends you see in the examples: a list of 7-integer actions such as "
    "[[x, y, z, roll, pitch, yaw, gripper_open], ...] and nothing else."
)


def task_line(instruction: str, objects: dict, workspace: Box, missing=()) -> str:
    """'{instruction}. Objects: {objects} >' (without the actions); missing names say 'not detected'."""
    text = instruction.strip().rstrip(".").strip()
    parts = [encoding.format_objects(objects, workspace)] if objects else []
    parts += [f"{name} not detected" for name in missing]
    return f"{text}. Objects: {', '.join(parts) or 'none'} >"


def demo_line(demo: Demo, workspace: Box) -> str:
    return f"{task_line(demo.instruction, demo.objects, workspace)} {encoding.format_actions(demo.key_actions, workspace)}"


@dataclass
class XicmPromptOptions:
    system_prompt: Optional[str] = None  # None: SYSTEM_PROMPT; "" sends no system message


class XicmPromptBuilder(PromptBuilder):
    def __init__(self, options: XicmPromptOptions | None = None):
        o = options if options is not None else XicmPromptOptions()
        self.system_prompt = SYSTEM_PROMPT if o.system_prompt is None else o.system_prompt

    def build(self, demos: list[Demo], query: Query, workspace: Box) -> Prompt:
        lines = [demo_line(d, workspace) for d in demos]
        lines.append(task_line(query.instruction, query.objects, workspace, query.missing))
        messages = []
        if self.system_prompt:
            messages.append({"role": "system", "content": self.system_prompt})
        messages.append({"role": "user", "content": "\n".join(lines)})
        return Prompt(messages=messages, demos=list(demos), query=query, workspace=workspace)


@hookimpl
def register_prompt_builders(register):
    register("xicm", XicmPromptBuilder, options=XicmPromptOptions)
