"""nearest_demo: the LLM-free baseline re-anchors the best demo's actions on the query objects."""

from __future__ import annotations

import json
import re

import pluggy
import pytest

from xicm.core.contracts import hookspecs
from xicm.core.text.encoding import format_actions, quantise
from xicm.core.contracts.errors import ConfigError
from xicm.core.assembly.plugins import Registry
from xicm.core.contracts.types import Demo, KeyAction, Prompt, Query
from xicm.plugins.llms import nearest_demo
from xicm.core.text.reanchor import reanchor
from xicm.plugins.llms.nearest_demo import NearestDemoLLM, NearestDemoOptions

WS = ((-0.3, -0.5, 0.6), (0.7, 0.5, 1.6))
Q1 = (0.0, 1.0, 0.0, 0.0)
Q2 = (0.9238795325112867, 0.0, 0.0, 0.3826834323650898)  # 45 degrees about z


def act(x, y, z, quat=Q1, grip=True):
    return KeyAction(position=(x, y, z), quat_wxyz=quat, gripper_open=grip)


def demo(objects, actions, demo_id="d0"):
    return Demo(demo_id=demo_id, task="close_jar", instruction="close the red jar", seed=0, episode=0,
                objects=objects, key_actions=actions)


def prompt(demos, query_objects):
    query = Query(task="close_microwave", instruction="close microwave", objects=query_objects)
    return Prompt(messages=[{"role": "user", "content": "x"}], demos=demos, query=query, workspace=WS)


def ints(text):
    return [[int(v) for v in g.split(",")] for g in re.findall(r"\[([-\d,\s]+)\]", text)]


def test_same_names_move_with_their_objects():
    d = demo(
        {"jar": (0.10, 0.00, 0.80), "lid": (0.20, 0.10, 0.80)},
        [act(0.20, 0.10, 0.90), act(0.20, 0.10, 0.82, grip=False), act(0.10, 0.00, 0.90, Q2, grip=False)],
    )
    q = {"lid": (0.00, 0.20, 0.80), "jar": (0.30, -0.10, 0.80)}  # different order, same names
    moved = reanchor(d, Query(task="t", instruction="i", objects=q))
    assert moved[0].position == pytest.approx((0.00, 0.20, 0.90))
    assert moved[1].position == pytest.approx((0.00, 0.20, 0.82))
    assert moved[2].position == pytest.approx((0.30, -0.10, 0.90))
    assert [a.quat_wxyz for a in moved] == [Q1, Q1, Q2]
    assert [a.gripper_open for a in moved] == [True, False, False]


def test_reply_is_the_llm_text_format():
    d = demo({"jar": (0.10, 0.00, 0.80)}, [act(0.12, 0.01, 0.95), act(0.12, 0.01, 0.85, grip=False)])
    p = prompt([d], {"jar": (0.25, 0.20, 0.80)})
    text = NearestDemoLLM().complete(p)
    expected = [act(0.27, 0.21, 0.95), act(0.27, 0.21, 0.85, grip=False)]
    assert text == format_actions(expected, WS)
    rows = ints(text)
    assert len(rows) == 2 and all(len(r) == 7 for r in rows)
    assert rows[0][6] == 1 and rows[1][6] == 0


def test_other_names_map_by_order():
    d = demo(
        {"jar": (0.10, 0.00, 0.80), "lid": (0.20, 0.10, 0.80)},
        [act(0.21, 0.10, 0.90), act(0.10, 0.01, 0.90)],
    )
    q = {"door": (0.40, -0.20, 0.85), "microwave": (0.50, 0.00, 0.85)}
    moved = reanchor(d, Query(task="t", instruction="i", objects=q))
    # action 0 is nearest the lid (index 1) -> microwave; action 1 nearest the jar (index 0) -> door
    assert moved[0].position == pytest.approx((0.51, 0.00, 0.95))
    assert moved[1].position == pytest.approx((0.40, -0.19, 0.95))


def test_fewer_query_objects_wrap_around():
    d = demo(
        {"a": (0.0, 0.0, 0.8), "b": (0.3, 0.3, 0.8), "c": (-0.2, 0.4, 0.8)},
        [act(-0.2, 0.4, 0.9)],  # nearest c (index 2) -> query index 2 % 2 = 0
    )
    moved = reanchor(d, Query(task="t", instruction="i", objects={"x": (0.1, 0.1, 0.8), "y": (0.2, 0.2, 0.8)}))
    assert moved[0].position == pytest.approx((0.1, 0.1, 0.9))


def test_uses_the_best_demo_only():
    best = demo({"jar": (0.1, 0.0, 0.8)}, [act(0.1, 0.0, 0.9)], "best")
    other = demo({"jar": (0.0, 0.0, 0.8)}, [act(0.0, 0.3, 1.2), act(0.0, 0.3, 1.1)], "other")
    p = prompt([best, other], {"jar": (0.2, 0.1, 0.8)})
    assert NearestDemoLLM().complete(p) == format_actions([act(0.2, 0.1, 0.9)], WS)
    assert len(ints(NearestDemoLLM(NearestDemoOptions(demo_rank=1)).complete(p))) == 2


def test_fallbacks():
    d = demo({}, [act(0.1, 0.0, 0.9)])
    assert NearestDemoLLM().complete(prompt([d], {"jar": (0.3, 0.3, 0.8)})) == format_actions(d.key_actions, WS)
    d2 = demo({"jar": (0.1, 0.0, 0.8)}, [act(0.1, 0.0, 0.9)])
    assert NearestDemoLLM().complete(prompt([d2], {})) == format_actions(d2.key_actions, WS)
    assert NearestDemoLLM().complete(prompt([], {"jar": (0.3, 0.3, 0.8)})) == "[]"


def test_quantised_round_trip_is_stable():
    d = demo({"jar": (0.1, 0.0, 0.8)}, [act(0.153, 0.021, 0.934, Q2, grip=False)])
    p = prompt([d], {"jar": (0.1, 0.0, 0.8)})
    assert NearestDemoLLM().complete(p) == format_actions([quantise(d.key_actions[0], WS)], WS)


def test_registered_as_plugin_and_identity():
    pm = pluggy.PluginManager("xicm")
    pm.add_hookspecs(hookspecs)
    pm.register(nearest_demo, name="xicm.plugins.llms.nearest_demo")
    registry = Registry(pm)
    llm = registry.create("llm", {"name": "nearest_demo"})
    assert isinstance(llm, NearestDemoLLM)
    assert json.loads(llm.identity()) == {"llm": "nearest_demo", "demo_rank": 0}
    with pytest.raises(ConfigError, match="unknown option.*k.*available: demo_rank"):
        registry.create("llm", {"name": "nearest_demo", "k": 3})


def test_nearest_demo_is_never_served_from_the_message_keyed_cache(tmp_path):
    """Two queries whose text rounds to the same voxels must still get their own replies."""
    from xicm.plugins.policies.xicm.llm_cache import CachedLLM
    from xicm.plugins.llms.nearest_demo import NearestDemoLLM, NearestDemoOptions

    assert CachedLLM(NearestDemoLLM(), tmp_path / "c.sqlite").enabled is False


def test_works_on_the_xicm_paper_prompt_from_its_demos_and_query():
    from xicm.plugins.prompts.xicm_paper import XicmPaperPromptBuilder

    d = demo({"red jar": (0.10, 0.00, 0.80)}, [act(0.12, 0.01, 0.95), act(0.12, 0.01, 0.85, grip=False)])
    query = Query(task="close_microwave", instruction="close microwave", objects={"microwave": (0.25, 0.20, 0.80)})
    built = XicmPaperPromptBuilder().build([d], query, WS)
    assert NearestDemoLLM().complete(built) == NearestDemoLLM().complete(prompt([d], {"microwave": (0.25, 0.20, 0.80)}))
    assert NearestDemoLLM().complete(built) == format_actions(reanchor(d, query), WS)
