"""Anchored actions (`prompt.actions: anchored`): demos' actions written relative to their
observation's objects, replies read back on the query's objects. Encoding, parsing (strict, partial,
X-ICM's reading), the prompt builder's text and anchors, and `nearest_demo` answering in that form."""

from __future__ import annotations

import pluggy
import pytest

from xicm.core.text import encoding
from xicm.core.contracts import hookspecs
from xicm.core.text.parsing import ParseError, parse_actions, parse_actions_xicm, partial_stop
from xicm.core.assembly.plugins import Registry
from xicm.core.text.reanchor import order_like_demo
from xicm.core.contracts.types import Demo, KeyAction, Prompt, Query
from xicm.plugins.llms.nearest_demo import NearestDemoLLM, NearestDemoOptions
from xicm.plugins.prompts import xicm_paper

WS = ((-0.3, -0.5, 0.6), (0.7, 0.5, 1.6))  # 1 cm voxels
UP = (1.0, 0.0, 0.0, 0.0)  # rotation bins [36, 36, 36]


def voxel(i, j, k):
    return (-0.3 + 0.01 * (i + 0.5), -0.5 + 0.01 * (j + 0.5), 0.6 + 0.01 * (k + 0.5))


def jar_demo():
    return Demo(
        demo_id="close_jar/s0/e0", task="close_jar", instruction="close the red jar", seed=0, episode=0,
        objects={"red jar": voxel(40, 50, 20), "green jar": voxel(45, 55, 20), "jar lid": voxel(30, 70, 20)},
        # above the lid, down onto it, then over the red jar
        key_actions=[KeyAction(voxel(30, 70, 25), UP, True), KeyAction(voxel(30, 70, 21), UP, False),
                     KeyAction(voxel(41, 50, 26), UP, False)],
    )


def hoop_query():
    return Query("basketball_in_hoop", "put the ball in the hoop", {"ball": voxel(30, 50, 20), "hoop": voxel(60, 70, 40)})


def builder(**options):
    pm = pluggy.PluginManager("xicm")
    pm.add_hookspecs(hookspecs)
    pm.register(xicm_paper)
    return Registry(pm).create("prompt", {"name": "xicm_paper", **options})


HOOP, BALL = voxel(60, 70, 40), voxel(30, 50, 20)  # the query's objects in the prompt's order (X-ICM's: hoop, ball)


def test_actions_are_written_on_their_nearest_object_and_read_back_on_the_query():
    demo = jar_demo()
    anchors = [demo.objects["jar lid"], demo.objects["red jar"]]
    text = encoding.format_actions(demo.key_actions, WS, anchors)
    assert text == "[[0, 0, 0, 5, 36, 36, 36, 1], [0, 0, 0, 1, 36, 36, 36, 0], [1, 1, 0, 6, 36, 36, 36, 0]]"
    actions = parse_actions(text, WS, anchors=[HOOP, BALL])  # the demo's motion moved onto hoop and ball
    assert [encoding.position_to_voxel(a.position, WS) for a in actions] == [(60, 70, 45), (60, 70, 41), (31, 50, 26)]
    assert [a.gripper_open for a in actions] == [True, False, False]
    # read on the demo's own objects, the text gives the demo's own voxels back
    back = parse_actions(text, WS, anchors=anchors)
    assert [encoding.action_to_ints(a, WS) for a in back] == [encoding.action_to_ints(a, WS) for a in demo.key_actions]


def test_an_object_index_past_the_query_objects_wraps_and_no_objects_anchor_on_the_origin():
    wrapped = parse_actions("[[3, 0, 0, 0, 36, 36, 36, 1]]", WS, anchors=[HOOP, BALL])
    assert encoding.position_to_voxel(wrapped[0].position, WS) == (30, 50, 20)  # 3 % 2 = 1: the ball
    origin = parse_actions("[[0, 7, 8, 9, 36, 36, 36, 1]]", WS, anchors=())
    assert encoding.position_to_voxel(origin[0].position, WS) == (7, 8, 9)
    assert encoding.format_actions([KeyAction(voxel(7, 8, 9), UP, True)], WS, []) == "[[0, 7, 8, 9, 36, 36, 36, 1]]"


def test_bad_anchored_replies_are_one_sentence():
    anchors = [HOOP, BALL]
    off = parse_actions("[[0, 0, 0, 70, 36, 36, 36, 1]]", WS, anchors=anchors)  # 40 + 70 = 110: off the grid
    assert isinstance(off, ParseError) and "out of range once anchored: [60, 70, 110" in off.reason
    negative = parse_actions("[[-1, 0, 0, 0, 36, 36, 36, 1]]", WS, anchors=anchors)
    assert isinstance(negative, ParseError) and "names object -1" in negative.reason
    absolute = parse_actions("[[60, 70, 45, 36, 36, 36, 1]]", WS, anchors=anchors)  # the other form
    assert isinstance(absolute, ParseError) and "[object, dx, dy, dz, roll, pitch, yaw, gripper] group of 8" in absolute.reason
    assert isinstance(parse_actions("[[0, 0, 0, 5, 36, 36, 36, 1]]", WS), ParseError)  # 8 items, absolute reading


def test_partial_and_xicm_readings_of_anchored_replies():
    anchors = [HOOP, BALL]
    reply = "[[0, 0, 0, 5, 36, 36, 36, 1], [1, 0, 0, 90, 36, 36, 36, 0], [1, 0, 0, 1, 36, 36, 36, 0]]"
    kept = parse_actions(reply, WS, partial=True, anchors=anchors)
    assert len(kept) == 1 and encoding.position_to_voxel(kept[0].position, WS) == (60, 70, 45)
    assert "out of range once anchored: [30, 50, 110" in partial_stop(reply, anchors=anchors, workspace=WS)
    actions, fallback = parse_actions_xicm(reply, WS, anchors)  # no range check, as X-ICM's reading
    assert fallback is None and len(actions) == 3
    assert encoding.position_to_voxel(actions[2].position, WS) == (30, 50, 21)
    none, why = parse_actions_xicm("[[60, 70, 45, 36, 36, 36, 1]]", WS, anchors)
    assert len(none) == 1 and why == "no group of 8 integers: one default action"


def test_the_prompt_writes_anchored_demos_and_passes_the_query_anchors():
    absolute = builder().build([jar_demo()], hoop_query(), WS)
    anchored = builder(actions="anchored").build([jar_demo()], hoop_query(), WS)
    assert absolute.anchors is None
    assert anchored.anchors == (HOOP, BALL)  # X-ICM lists the hoop first
    assert anchored.messages[-1]["content"] == (
        "['instruction': close the red jar, {'lid': [30, 70, 20], 'jar': [40, 50, 20]}]>"
        "[[0, 0, 0, 5, 36, 36, 36, 1], [0, 0, 0, 1, 36, 36, 36, 0], [1, 1, 0, 6, 36, 36, 36, 0]], "
        "['instruction': put the ball in the hoop, {'hoop': [60, 70, 40], 'ball': [30, 50, 20]}]>"
    )
    assert anchored.messages[0]["content"] == xicm_paper.SYSTEM_PROMPT_ANCHORED
    with pytest.raises(Exception, match="absolute, anchored"):
        builder(actions="relative")


def test_nearest_demo_answers_in_the_prompt_form_with_the_same_actions():
    llm = NearestDemoLLM()
    absolute = builder().build([jar_demo()], hoop_query(), WS)
    anchored = builder(actions="anchored").build([jar_demo()], hoop_query(), WS)
    plain = parse_actions(llm.complete(absolute), WS)
    moved = parse_actions(llm.complete(anchored), WS, anchors=anchored.anchors)
    assert [encoding.action_to_ints(a, WS) for a in moved] == [encoding.action_to_ints(a, WS) for a in plain]


def jar_query():
    """A query of a task X-ICM lists no objects for (so its scene's own names and order): the lid's
    and the red jar's roles are the demo's, listed the other way round."""
    return Query("stack_jars", "put the lid on the red jar", {"red jar": voxel(50, 30, 20), "jar lid": voxel(20, 40, 20)})


def ints(actions):
    return [encoding.action_to_ints(a, WS) for a in actions]


def test_query_order_first_demo_lists_the_query_objects_where_the_replay_moves_the_demo_objects():
    own = builder(actions="anchored").build([jar_demo()], jar_query(), WS)
    aligned = builder(actions="anchored", query_order="first_demo").build([jar_demo()], jar_query(), WS)
    assert own.anchors == (voxel(50, 30, 20), voxel(20, 40, 20))  # the scene's order: red jar, jar lid
    assert aligned.anchors == (voxel(20, 40, 20), voxel(50, 30, 20))  # the demo lists its lid first
    assert aligned.demo_anchors == own.demo_anchors == ((voxel(30, 70, 20), voxel(40, 50, 20)),)
    assert aligned.messages[-1]["content"].endswith(
        "['instruction': put the lid on the red jar, {'jar lid': [20, 40, 20], 'red jar': [50, 30, 20]}]>")
    with pytest.raises(Exception, match="own, first_demo"):
        builder(query_order="alphabetical")


def test_a_copy_of_the_first_demo_lands_where_the_replay_does_only_with_the_aligned_order():
    copy, replay = NearestDemoLLM(NearestDemoOptions(reply="copy")), NearestDemoLLM()
    own = builder(actions="anchored").build([jar_demo()], jar_query(), WS)
    aligned = builder(actions="anchored", query_order="first_demo").build([jar_demo()], jar_query(), WS)
    # the copy is the demo's list exactly as the prompt writes it
    assert copy.complete(own) == copy.complete(aligned) == "[[0, 0, 0, 5, 36, 36, 36, 1], [0, 0, 0, 1, 36, 36, 36, 0], [1, 1, 0, 6, 36, 36, 36, 0]]"
    assert copy.complete(own) in own.messages[-1]["content"]
    replayed = ints(parse_actions(replay.complete(aligned), WS, anchors=aligned.anchors))
    assert replayed == ints(parse_actions(replay.complete(own), WS, anchors=own.anchors))  # the order does not move the replay
    assert ints(parse_actions(copy.complete(aligned), WS, anchors=aligned.anchors)) == replayed
    assert ints(parse_actions(copy.complete(own), WS, anchors=own.anchors)) != replayed  # the lid's actions on the red jar


def test_copy_in_the_absolute_form_and_without_demo_anchors():
    copy = NearestDemoLLM(NearestDemoOptions(reply="copy"))
    absolute = builder().build([jar_demo()], jar_query(), WS)
    assert copy.complete(absolute) == encoding.format_actions(jar_demo().key_actions, WS)
    anchored = builder(actions="anchored").build([jar_demo()], jar_query(), WS)
    bare = Prompt(messages=anchored.messages, demos=anchored.demos, query=anchored.query, workspace=WS, anchors=anchored.anchors)
    with pytest.raises(ValueError, match="llm.reply=copy needs a prompt"):
        copy.complete(bare)
    assert '"reply": "copy"' in copy.identity() and "reply" not in NearestDemoLLM().identity()


def test_order_like_demo_keeps_left_over_objects_in_order_and_needs_scene_objects():
    demo = jar_demo()
    query = Query("t", "i", {"a": voxel(1, 1, 1), "b": voxel(2, 2, 2), "c": voxel(3, 3, 3)})
    listed = dict(query.objects)
    # demo objects red jar (0), green jar (1), jar lid (2) -> query a, b, c by place; one shown demo object: the lid
    assert order_like_demo({"lid": demo.objects["jar lid"]}, demo, listed, query) == ["c", "a", "b"]
    bare = Query("t", "i", {})
    assert order_like_demo({"lid": demo.objects["jar lid"]}, demo, {"x": voxel(0, 0, 0)}, bare) == ["x"]
