"""Prompt builder "xicm_paper": the prompt layout of X-ICM's released code.

One user message on a single line: every demonstration, best first, as `obs>actions, ` and then
the query as `obs>`, where

    obs     = ['instruction': {instruction}, {'label': [x, y, z], ...}]
    actions = [[x, y, z, roll, pitch, yaw, open], ...]

The object dict is Python's own text of a dict of voxel lists, as X-ICM prints it; its objects are
the ones X-ICM hand-picks per task (xicm_paper_objects.PAPER_OBJECTS), under X-ICM's labels.
Objects the detector did not find are left out, as X-ICM leaves out objects no camera sees. The
system message says what X-ICM's says, in our words. Integers come from xicm.core.text.encoding.

Options:
    system_prompt: replaces the default system message (a string; may be empty to send none).
    objects: paper (X-ICM's per-task objects) | all (every object of the task, under our names).
    all_labels: with objects: paper, also X-ICM's labels of scene parts our scene has as parts of
        their own (xicm_paper_objects.PARTS; the policy asks the detector for them: scene_parts).
    actions: absolute (X-ICM's 7 integers) | anchored: each action written relative to one of its
        observation's objects, [object, dx, dy, dz, roll, pitch, yaw, open] (xicm.core.text.encoding,
        "anchored actions"), and the reply read back the same way on the query's objects
        (Prompt.anchors). Not X-ICM's: an option of ours, off in the paper presets.
    query_order: own (the query's objects in the order `objects` gives them) | first_demo: the
        query's objects reordered so that place i holds the object the `nearest_demo` replay moves
        the first demo's i-th object onto (xicm.core.text.reanchor.order_like_demo); with anchored
        actions a list copied whole from the first demo then lands where the replay's does. The
        observation still gives every object its own label and voxel. Not X-ICM's: an option of ours.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

from xicm.core.text import encoding
from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.interfaces import Box, PromptBuilder
from xicm.core.text.reanchor import order_like_demo
from xicm.core.contracts.schema import one_of
from xicm.core.contracts.types import Demo, Prompt, Query

from .xicm_paper_objects import paper_objects, part_names

SYSTEM_PROMPT = (
    "You are controlling a Franka Panda arm fitted with a parallel gripper. "
    "First come demonstrations of tasks you already know, each written as "
    "[task_instruction, observation]>[ 7-dim action_1, 7-dim action_2, ..., 7-dim action_N ]. "
    "Last comes the instruction of a task you have not seen, with a new observation. "
    "Reply with a list of 7-dim actions for it that follows the trends of the demonstrations, "
    "and with nothing else."
)

SYSTEM_PROMPT_ANCHORED = (
    "You are controlling a Franka Panda arm fitted with a parallel gripper. "
    "First come demonstrations of tasks you already know, each written as "
    "[task_instruction, observation]>[ action_1, action_2, ..., action_N ]. "
    "An observation lists the task's objects, each with the [x, y, z] voxel of its centre. "
    "An action is 8 integers [object, dx, dy, dz, roll, pitch, yaw, gripper_open]: object is the place "
    "of an object in that observation's list (0 for the first), and dx, dy, dz are the gripper's "
    "offset in voxels from that object. "
    "Last comes the instruction of a task you have not seen, with a new observation. "
    "Reply with a list of 8-integer actions for it that follows the trends of the demonstrations, "
    "and with nothing else."
)
ACTION_FORMS = ("absolute", "anchored")
QUERY_ORDERS = ("own", "first_demo")


def shown_objects(task: str, objects: dict, which: str, all_labels: bool = False) -> dict:
    """The objects the observation names, label -> position (metres), in the order it lists them."""
    return paper_objects(task, objects, all_labels) if which == "paper" else dict(objects)


def observation_text(instruction: str, shown: dict, workspace: Box) -> str:
    """"['instruction': {instruction}, {'label': [x, y, z], ...}]" (no quotes around the instruction)."""
    voxels = {label: list(encoding.position_to_voxel(xyz, workspace)) for label, xyz in shown.items()}
    return f"['instruction': {instruction.strip()}, {voxels!r}]"


@dataclass
class XicmPaperPromptOptions:
    system_prompt: Optional[str] = None  # None: SYSTEM_PROMPT; "" sends no system message
    objects: str = field(default="paper", metadata=one_of("paper", "all"))
    all_labels: bool = False  # also X-ICM's labels of scene parts our scene has (objects: paper)
    actions: str = field(default="absolute", metadata=one_of(*ACTION_FORMS))  # anchored: module docstring
    query_order: str = field(default="own", metadata=one_of(*QUERY_ORDERS))  # first_demo: module docstring


class XicmPaperPromptBuilder(PromptBuilder):
    def __init__(self, options: XicmPaperPromptOptions | None = None):
        o = options if options is not None else XicmPaperPromptOptions()
        self.anchored = o.actions == "anchored"
        default_system = SYSTEM_PROMPT_ANCHORED if self.anchored else SYSTEM_PROMPT
        self.system_prompt = default_system if o.system_prompt is None else o.system_prompt
        self.objects = o.objects
        self.all_labels = o.all_labels and o.objects == "paper"
        self.query_order = o.query_order

    def scene_parts(self, task: str) -> list[str]:
        return part_names(task) if self.all_labels else []

    def build(self, demos: list[Demo], query: Query, workspace: Box) -> Prompt:
        def shown(task: str, objects: dict) -> dict:
            return shown_objects(task, objects, self.objects, self.all_labels)

        def actions_text(demo: Demo, objects: dict) -> str:
            anchors = list(objects.values()) if self.anchored else None
            return encoding.format_actions(demo.key_actions, workspace, anchors)

        def points(objects: dict) -> tuple:
            return tuple(tuple(float(v) for v in xyz) for xyz in objects.values())

        text = ""
        demo_objects = [shown(d.task, d.objects) for d in demos]
        for d, objects in zip(demos, demo_objects):
            text += f"{observation_text(d.instruction, objects, workspace)}>{actions_text(d, objects)}, "
        query_objects = shown(query.task, query.objects)
        if self.query_order == "first_demo" and demos:
            order = order_like_demo(demo_objects[0], demos[0], query_objects, query)
            query_objects = {label: query_objects[label] for label in order}
        text += observation_text(query.instruction, query_objects, workspace) + ">"
        messages = [{"role": "system", "content": self.system_prompt}] if self.system_prompt else []
        messages.append({"role": "user", "content": text})
        if not self.anchored:
            return Prompt(messages=messages, demos=list(demos), query=query, workspace=workspace)
        return Prompt(
            messages=messages, demos=list(demos), query=query, workspace=workspace,
            anchors=points(query_objects), demo_anchors=tuple(points(o) for o in demo_objects),
        )


@hookimpl
def register_prompt_builders(register):
    register("xicm_paper", XicmPaperPromptBuilder, options=XicmPaperPromptOptions)
