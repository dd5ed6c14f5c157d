"""Moving a demo's key actions onto a query's objects (the replay of the `nearest_demo` baseline),
and listing the query's objects in the order that move puts them.

The rule, for one demo and one query (positions in metres, object dicts name -> centre):

1. For each key action of the demo, the *anchor* is the demo object whose first-frame centre
   is nearest (Euclidean) to the action's position.
2. The anchor is mapped to a query object: the query object with the same name when there is
   one; otherwise the query object at the anchor's index in the demo's object order (index
   taken modulo the number of query objects when the query has fewer objects).
3. The new action is placed at that query object's centre plus the action's offset from its
   anchor (``query_obj + (action - anchor)``); rotation and gripper state are copied.

A demo or query without objects gives the demo's actions unchanged.
"""

from __future__ import annotations

from typing import Mapping, Sequence

from xicm.core.text.encoding import nearest_anchor
from xicm.core.contracts.types import Demo, KeyAction, Query


def nearest_name(objects: Mapping[str, Sequence[float]], point: Sequence[float]) -> str:
    """The key of `objects` whose position is nearest to `point` (the first on a tie)."""
    return list(objects)[nearest_anchor(point, list(objects.values()))]


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
        anchor = nearest_name(demo.objects, action.position)
        target = query.objects[map_object(anchor, demo, query)]
        offset = [a - b for a, b in zip(action.position, demo.objects[anchor])]
        position = tuple(float(t + o) for t, o in zip(target, offset))
        actions.append(KeyAction(position=position, quat_wxyz=action.quat_wxyz, gripper_open=action.gripper_open))
    return actions


def order_like_demo(demo_listed: Mapping[str, Sequence[float]], demo: Demo, query_listed: Mapping[str, Sequence[float]], query: Query) -> list[str]:
    """The keys of `query_listed` reordered so that place i holds the query object the rule above
    maps the demo's i-th listed object onto.

    `demo_listed` / `query_listed` are the objects a prompt shows (label -> centre, in its order);
    each shown object is taken to be the scene object (`demo.objects` / `query.objects`) at its
    centre. Place i gets the shown query object nearest the mapped object's centre, among those not
    yet placed; shown query objects left over keep their order after them. So a list of anchored
    actions copied whole from the demo lands, object for object, where the replay moves them.
    Without scene objects on either side the order is unchanged.
    """
    if not demo.objects or not query.objects:
        return list(query_listed)
    order: list[str] = []
    free = dict(query_listed)
    for centre in demo_listed.values():
        if not free:
            break
        target = query.objects[map_object(nearest_name(demo.objects, centre), demo, query)]
        label = nearest_name(free, target)
        order.append(label)
        del free[label]
    return order + list(free)
