"""prompt.all_labels: X-ICM's labels of scene parts, found by the oracle detector on a real scene
and shown in X-ICM's order; the policy asks the detector for the parts the prompt shows."""

import numpy as np

from xicm.core.text import encoding
from xicm.core.execution.episode import run_episode
from xicm.core.contracts.interfaces import LLM
from xicm.core.assembly.plugins import get_registry
from xicm.core.contracts.types import Demo, KeyAction, Query
from xicm.plugins.policies.xicm.policy import XICMPolicy
from xicm.plugins.prompts.xicm_paper_objects import PAPER_OBJECTS, PARTS, part_names

UP = (1.0, 0.0, 0.0, 0.0)


class Recording(LLM):
    """Test LLM: keeps every prompt, answers one action that leaves the scene as it is."""

    deterministic = True

    def __init__(self):
        self.prompts = []

    def complete(self, prompt):
        self.prompts.append(prompt)
        return "[[40, 50, 60, 0, 36, 36, 1]]"


def _query_text(prompt):
    return prompt.messages[-1]["content"].rsplit(", ['instruction'", 1)[-1]


def test_every_part_entry_names_a_task_in_the_table():
    assert all(label in dict((lab, p) for p, lab in PAPER_OBJECTS[task]) for task, label in PARTS)
    assert part_names("beat_the_buzz") == ["buzz wire stand"] and part_names("close_jar") == []


def test_the_stand_label_comes_from_the_scene_through_the_oracle_detector(sim):
    obs = sim.reset("beat_the_buzz", 0, 0)
    assert "buzz wire stand" in obs.segment_names.values() and "buzz wire stand" not in obs.object_names
    reg = get_registry()
    builder = reg.create("prompt", {"name": "xicm_paper", "all_labels": True})
    names = list(obs.object_names) + builder.scene_parts("beat_the_buzz")
    found = reg.create("detector", {"name": "oracle"}).detect(obs, names)
    stand = np.asarray(sim.task.stand.get_pose().p)  # the stand's base centre (the task's own actor)
    query = Query("beat_the_buzz", obs.instruction, found, None, ())
    text = builder.build([], query, sim.workspace).messages[-1]["content"]
    cube = list(encoding.position_to_voxel(found["buzz wire stand"], sim.workspace))
    pole = list(encoding.position_to_voxel(found["wand"], sim.workspace))
    assert text.endswith(f"{{'cube': {cube}, 'pole': {pole}}}]>")  # X-ICM's order: Cuboid first
    # the visible points' centre lies over the stand's base
    assert np.linalg.norm(np.asarray(found["buzz wire stand"])[:2] - stand[:2]) < 0.05
    plain = reg.create("prompt", {"name": "xicm_paper"})
    assert plain.scene_parts("beat_the_buzz") == []
    assert plain.build([], query, sim.workspace).messages[-1]["content"].endswith(f"{{'pole': {pole}}}]>")


def test_the_policy_asks_the_detector_for_the_parts_the_prompt_shows(sim):
    reg = get_registry()
    demo = Demo("close_jar/s0/e0", "close_jar", "close the red jar", 0, 0, {"jar lid": (0.2, 0.1, 0.8)},
                [KeyAction((0.2, 0.1, 0.9), UP, True)])
    texts = {}
    for all_labels in (True, False):
        llm = Recording()
        policy = XICMPolicy(
            detector=reg.create("detector", {"name": "oracle"}),
            retriever=reg.create("retriever", {"name": "random"}, encoder=None),
            prompt_builder=reg.create("prompt", {"name": "xicm_paper", "all_labels": all_labels}),
            llm=llm, pool=[demo], workspace=sim.workspace, k=1,
        )
        run_episode(sim, policy, "beat_the_buzz", 0, 0, max_steps=1)
        texts[all_labels] = _query_text(llm.prompts[0])
    assert "'cube': [" in texts[True] and texts[True].index("'cube'") < texts[True].index("'pole'")
    assert "'cube'" not in texts[False] and "'pole': [" in texts[False]


def test_a_duck_typed_prompt_builder_without_scene_parts_still_works(sim):
    reg = get_registry()

    class OnlyBuild:  # not a PromptBuilder subclass: scene_parts is optional
        def __init__(self):
            self.inner = reg.create("prompt", {"name": "xicm_paper"})

        def build(self, demos, query, workspace):
            return self.inner.build(demos, query, workspace)

    llm = Recording()
    demo = Demo("close_jar/s0/e0", "close_jar", "close the red jar", 0, 0, {}, [KeyAction((0.2, 0.1, 0.9), UP, True)])
    policy = XICMPolicy(detector=reg.create("detector", {"name": "oracle"}),
                        retriever=reg.create("retriever", {"name": "random"}, encoder=None),
                        prompt_builder=OnlyBuild(), llm=llm, pool=[demo], workspace=sim.workspace, k=1)
    result = run_episode(sim, policy, "beat_the_buzz", 0, 0, max_steps=1)
    assert result.error_kind != "detector_error" and "'pole': [" in _query_text(llm.prompts[0])
