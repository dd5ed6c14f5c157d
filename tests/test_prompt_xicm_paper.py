"""Prompt builder "xicm_paper": X-ICM's one-line layout, object text and per-task objects."""

import pluggy
import pytest

from xicm.core.contracts import hookspecs
from xicm.core.contracts.errors import ConfigError
from xicm.core.assembly.plugins import Registry
from xicm.core.contracts.types import Demo, KeyAction, Query
from xicm.plugins.prompts import xicm_paper
from xicm.plugins.prompts.xicm_paper_objects import PAPER_OBJECTS, paper_objects

WS = ((-0.3, -0.5, 0.6), (0.7, 0.5, 1.6))  # 1 cm voxels: x = -0.3 + 0.01 * (i + 0.5)
UP = (1.0, 0.0, 0.0, 0.0)  # identity quaternion: bins [36, 36, 36]


def voxel(i, j, k):
    return (-0.3 + 0.01 * (i + 0.5), -0.5 + 0.01 * (j + 0.5), 0.6 + 0.01 * (k + 0.5))


def jar_demo(tag="0", objects=None):
    return Demo(
        demo_id=f"close_jar/s0/e{tag}",
        task="close_jar",
        instruction="close the red jar",
        seed=0,
        episode=0,
        objects=objects or {"red jar": voxel(40, 50, 20), "green jar": voxel(45, 55, 20), "jar lid": voxel(30, 70, 20)},
        key_actions=[KeyAction(voxel(30, 70, 25), UP, True), KeyAction(voxel(30, 70, 21), UP, False)],
    )


def hoop_query(objects=None):
    objects = {"ball": voxel(30, 50, 20), "hoop": voxel(60, 70, 40)} if objects is None else objects
    return Query("basketball_in_hoop", "put the ball in the hoop", objects)


def builder(**options):
    pm = pluggy.PluginManager("xicm")
    pm.add_hookspecs(hookspecs)
    pm.register(xicm_paper)
    return Registry(pm).create("prompt", {"name": "xicm_paper", **options})


def user_text(prompt):
    return prompt.messages[-1]["content"]


def test_one_demo_one_query_golden_text():
    prompt = builder().build([jar_demo()], hoop_query(), WS)
    assert user_text(prompt) == (
        "['instruction': close the red jar, {'lid': [30, 70, 20], 'jar': [40, 50, 20]}]>"
        "[[30, 70, 25, 36, 36, 36, 1], [30, 70, 21, 36, 36, 36, 0]], "
        "['instruction': put the ball in the hoop, {'hoop': [60, 70, 40], 'ball': [30, 50, 20]}]>"
    )
    assert prompt.messages[0] == {"role": "system", "content": xicm_paper.SYSTEM_PROMPT}


def test_demos_stay_in_the_given_order_best_first():
    first = jar_demo(objects={"red jar": voxel(1, 1, 1), "jar lid": voxel(2, 2, 2)})
    second = jar_demo(objects={"red jar": voxel(9, 9, 9), "jar lid": voxel(8, 8, 8)})
    text = user_text(builder().build([first, second], hoop_query(), WS))
    assert text.index("'jar': [1, 1, 1]") < text.index("'jar': [9, 9, 9]")


@pytest.mark.parametrize("k", [0, 1, 5])
def test_k_demos_give_k_segments_on_one_line(k):
    text = user_text(builder().build([jar_demo(str(i)) for i in range(k)], hoop_query(), WS))
    assert "\n" not in text
    assert text.count("]>[[") == k
    assert text.count("]], ") == k and text.endswith("]>")


def test_per_task_objects_use_upstream_labels_in_upstream_order():
    objects = {"charger": voxel(1, 2, 3), "wall socket": voxel(4, 5, 6), "wall": voxel(7, 8, 9)}
    assert paper_objects("unplug_charger", objects) == {"charger": voxel(1, 2, 3), "wall": voxel(7, 8, 9)}
    rope = {n: voxel(i, i, i) for i, n in enumerate(("rope", "rope head", "rope tail", "head target", "tail target"))}
    assert list(paper_objects("straighten_rope", rope)) == ["rope head", "rope head target", "rope head tail", "rope tail"]


def test_a_pattern_takes_each_object_once_in_episode_order():
    spokes = {"square ring": voxel(0, 0, 0), "blue spoke": voxel(1, 1, 1), "red spoke": voxel(2, 2, 2), "green spoke": voxel(3, 3, 3)}
    chosen = paper_objects("insert_onto_square_peg", spokes)
    assert chosen == {"ring": voxel(0, 0, 0), "first spok": voxel(1, 1, 1), "second spok": voxel(2, 2, 2), "third spok": voxel(3, 3, 3)}


def test_an_undetected_object_is_left_out():
    text = user_text(builder().build([], hoop_query({"ball": voxel(30, 50, 20)}), WS))
    assert text == "['instruction': put the ball in the hoop, {'ball': [30, 50, 20]}]>"


def test_a_task_missing_from_the_table_keeps_all_its_objects_under_their_names():
    query = Query("my_new_task", "do it", {"thing": voxel(1, 2, 3), "other thing": voxel(4, 5, 6)})
    text = user_text(builder().build([], query, WS))
    assert text == "['instruction': do it, {'thing': [1, 2, 3], 'other thing': [4, 5, 6]}]>"


def test_objects_all_shows_every_object_under_our_names():
    text = user_text(builder(objects="all").build([], hoop_query(), WS))
    assert "{'ball': [30, 50, 20], 'hoop': [60, 70, 40]}" in text


def test_table_covers_the_41_agnostos_tasks_with_one_to_seven_objects():
    from xicm.plugins.simulators.sapien.tasks import seen, unseen  # noqa: F401  (task modules are plain files)
    import pkgutil

    names = {m.name for pkg in (seen, unseen) for m in pkgutil.iter_modules(pkg.__path__)}
    assert len(names) == 41 and names <= set(PAPER_OBJECTS)
    assert all(1 <= len(entries) <= 7 for entries in PAPER_OBJECTS.values())


def test_empty_system_prompt_sends_only_the_user_message():
    prompt = builder(system_prompt="").build([jar_demo()], hoop_query(), WS)
    assert [m["role"] for m in prompt.messages] == ["user"]


def test_unknown_objects_choice_is_one_clear_sentence():
    with pytest.raises(ConfigError, match="objects"):
        builder(objects="some")


def test_prompt_keeps_structured_demos_and_query_for_llm_free_baselines():
    demos, query = [jar_demo()], hoop_query()
    prompt = builder().build(demos, query, WS)
    assert prompt.demos == demos and prompt.query is query and prompt.workspace == WS
