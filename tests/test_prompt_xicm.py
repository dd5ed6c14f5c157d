"""Prompt builder "xicm"."""

import re

import numpy as np
import pluggy

from xicm.core.text import encoding
from xicm.core.contracts import hookspecs
from xicm.core.assembly.plugins import Registry
from xicm.core.contracts.types import Demo, KeyAction, Prompt, Query
from xicm.plugins.prompts import xicm_prompt

WS = ((-0.3, -0.5, 0.6), (0.7, 0.5, 1.6))


def random_action(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    return KeyAction(tuple(rng.uniform(WS[0], WS[1])), tuple(q), bool(rng.integers(2)))


def make_demo(i, rng, n_actions=3):
    return Demo(
        demo_id=f"task{i}/s0/e{i:04d}",
        task=f"task{i}",
        instruction=f"do thing number {i}",
        seed=0,
        episode=i,
        objects={f"obj{i}_a": tuple(rng.uniform(WS[0], WS[1])), f"obj{i}_b": tuple(rng.uniform(WS[0], WS[1]))},
        key_actions=[random_action(rng) for _ in range(n_actions)],
    )


def builder(**options):
    pm = pluggy.PluginManager("xicm")
    pm.add_hookspecs(hookspecs)
    pm.register(xicm_prompt)
    return Registry(pm).create("prompt", {"name": "xicm", **options})


def test_structure_order_and_query_last():
    rng = np.random.default_rng(0)
    demos = [make_demo(i, rng) for i in (3, 1, 2)]  # best first, as the retriever gave them
    query = Query(task="close_fridge", instruction="close fridge", objects={"fridge door": (0.2, 0.1, 1.0)})
    p = builder().build(demos, query, WS)
    assert isinstance(p, Prompt) and p.demos == demos and p.query is query and p.workspace == WS
    assert [m["role"] for m in p.messages] == ["system", "user"]
    system = p.messages[0]["content"]
    assert "Franka Panda" in system and "100x100x100" in system and "72" in system
    lines = p.messages[1]["content"].split("\n")
    assert len(lines) == 4
    assert [ln.split(".")[0] for ln in lines[:3]] == [d.instruction for d in demos]  # order preserved
    assert lines[-1] == f"close fridge. Objects: fridge door {encoding.format_ints(encoding.position_to_voxel((0.2, 0.1, 1.0), WS))} >"
    assert lines[-1].endswith(">")
    for line, d in zip(lines[:3], demos):
        assert line == (
            f"{d.instruction}. Objects: {encoding.format_objects(d.objects, WS)} > "
            f"{encoding.format_actions(d.key_actions, WS)}"
        )


def test_integers_round_trip_through_the_encoding():
    rng = np.random.default_rng(1)
    d = make_demo(0, rng, n_actions=5)
    p = builder().build([d], Query(task="t", instruction="q", objects={}), WS)
    demo_text = p.messages[-1]["content"].split("\n")[0]
    objects_text, actions_text = demo_text.split(" > ")
    groups = [[int(v) for v in g.split(",")] for g in re.findall(r"\[([-\d, ]+)\]", actions_text)]
    assert len(groups) == 5 and all(len(g) == 7 for g in groups)
    for g, a in zip(groups, d.key_actions):
        assert g == encoding.action_to_ints(a, WS)
        decoded = encoding.ints_to_action(g, WS)
        assert np.allclose(decoded.position, a.position, atol=0.01)  # within one 1 cm voxel
        assert decoded.gripper_open == a.gripper_open
        assert encoding.action_to_ints(decoded, WS) == g  # decoding then encoding is stable
    voxels = [[int(v) for v in g.split(",")] for g in re.findall(r"\[([-\d, ]+)\]", objects_text)]
    assert voxels == [list(encoding.position_to_voxel(xyz, WS)) for xyz in d.objects.values()]
    assert p.messages[-1]["content"].split("\n")[-1] == "q. Objects: none >"


def test_system_prompt_override_and_no_demos():
    q = Query(task="t", instruction="turn on the light.", objects={"lamp": (0.0, 0.0, 1.0)})
    p = builder(system_prompt="Be brief.").build([], q, WS)
    assert p.messages[0] == {"role": "system", "content": "Be brief."}
    assert p.messages[1]["content"].startswith("turn on the light. Objects: lamp [")  # no double period
    assert [m["role"] for m in builder(system_prompt="").build([], q, WS).messages] == ["user"]


def test_objects_the_detector_missed_are_named_as_not_detected():
    query = Query("close_fridge", "close fridge", {"fridge": (0.2, 0.1, 1.0)}, missing=("fridge top door", "handle"))
    p = builder().build([], query, WS)
    voxel = encoding.format_ints(encoding.position_to_voxel((0.2, 0.1, 1.0), WS))
    assert p.messages[1]["content"] == f"close fridge. Objects: fridge {voxel}, fridge top door not detected, handle not detected >"
    assert "'not detected'" in p.messages[0]["content"]
    nothing = builder().build([], Query("t", "do it", {}, missing=("cup",)), WS)
    assert nothing.messages[1]["content"] == "do it. Objects: cup not detected >"
