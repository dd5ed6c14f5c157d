import pytest

from xicm.core import encoding, parsing
from xicm.core.types import KeyAction

WS = ((-0.3, -0.5, 0.6), (0.7, 0.5, 1.6))


def test_parses_the_innermost_seven_integer_groups_in_order():
    text = "Sure! [[50, 50, 30, 0, 36, 36, 1], [50, 50, 20, 0, 36, 36, 0]] done"
    actions = parsing.parse_actions(text, WS)
    assert isinstance(actions, list) and len(actions) == 2
    assert all(isinstance(a, KeyAction) for a in actions)
    assert [encoding.action_to_ints(a, WS) for a in actions] == [[50, 50, 30, 0, 36, 36, 1], [50, 50, 20, 0, 36, 36, 0]]


def test_ignores_groups_that_are_not_seven_integers():
    text = "objects: drawer [1, 2, 3]; bad [1, 2, 3, 4, 5, 6, 7.5]; ok [1, 2, 3, 4, 5, 6, 1]"
    assert parsing.parse_action_ints(text) == [[1, 2, 3, 4, 5, 6, 1]]


def test_keeps_at_most_26_actions():
    text = "[" + ", ".join("[1, 2, 3, 4, 5, 6, 1]" for _ in range(40)) + "]"
    assert len(parsing.parse_action_ints(text)) == 26


@pytest.mark.parametrize(
    "reply, reason",
    [
        ("", "empty"),
        ("   \n", "empty"),
        ("I cannot help with that.", "no [x, y, z"),
        ("[[1, 2, 3]]", "no [x, y, z"),
        ("[[120, 2, 3, 4, 5, 6, 1]]", "out of range"),
        ("[[1, 2, 3, 4, 5, 6, 3]]", "out of range"),
        (None, "not text"),
        (42, "not text"),
    ],
)
def test_garbage_gives_a_parse_error_with_a_reason(reply, reason):
    result = parsing.parse_actions(reply, WS)
    assert isinstance(result, parsing.ParseError)
    assert result.kind == "parse_error"
    assert reason in result.reason


def test_never_raises_on_random_text():
    import random

    rnd = random.Random(0)
    alphabet = "[],- 0123456789abc\n"
    for _ in range(500):
        text = "".join(rnd.choice(alphabet) for _ in range(rnd.randint(0, 200)))
        out = parsing.parse_actions(text, WS)
        assert isinstance(out, (list, parsing.ParseError))


def _ints(actions):
    return [encoding.action_to_ints(a, WS) for a in actions]


def test_partial_keeps_the_actions_before_the_first_out_of_range_one():
    text = "[[50, 50, 30, 0, 36, 36, 1], [50, 50, 20, 0, 36, 36, 0], [120, 50, 20, 0, 36, 36, 0], [1, 2, 3, 4, 5, 6, 1]]"
    assert _ints(parsing.parse_actions(text, WS, partial=True)) == [[50, 50, 30, 0, 36, 36, 1], [50, 50, 20, 0, 36, 36, 0]]
    assert parsing.partial_stop(text) == "action [120, 50, 20, 0, 36, 36, 0] is out of range (position 0-99, rotation 0-72, gripper 0/1)"


def test_partial_stops_at_a_seven_item_group_that_is_not_all_integers():
    text = "[[50, 50, 30, 0, 36, 36, 1], [50, 50, 2.5, 0, 36, 36, 0], [1, 2, 3, 4, 5, 6, 1]]"
    assert _ints(parsing.parse_actions(text, WS, partial=True)) == [[50, 50, 30, 0, 36, 36, 1]]
    assert parsing.partial_stop(text) == "action [50, 50, 2.5, 0, 36, 36, 0] is not 7 integers"


def test_partial_still_skips_groups_of_other_lengths_like_the_default():
    text = "drawer [1, 2, 3] then [[50, 50, 30, 0, 36, 36, 1]]"
    assert _ints(parsing.parse_actions(text, WS, partial=True)) == [[50, 50, 30, 0, 36, 36, 1]]
    assert parsing.partial_stop(text) is None


def test_partial_reply_whose_first_action_is_invalid_is_a_parse_error():
    result = parsing.parse_actions("[[50, 50, 30, 0, 36, 36, 5], [50, 50, 30, 0, 36, 36, 1]]", WS, partial=True)
    assert isinstance(result, parsing.ParseError)
    assert result.reason == "the first action [50, 50, 30, 0, 36, 36, 5] is out of range (position 0-99, rotation 0-72, gripper 0/1)"


def test_default_still_rejects_a_reply_with_any_out_of_range_action():
    result = parsing.parse_actions("[[50, 50, 30, 0, 36, 36, 1], [120, 50, 20, 0, 36, 36, 0]]", WS)
    assert isinstance(result, parsing.ParseError) and "out of range" in result.reason


def test_partial_keeps_at_most_26_actions():
    text = "[" + ", ".join("[1, 2, 3, 4, 5, 6, 1]" for _ in range(40)) + "]"
    assert len(parsing.parse_actions(text, WS, partial=True)) == 26
    assert parsing.partial_stop(text) is None
