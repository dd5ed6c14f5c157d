import pytest

from xicm.core.text import encoding, parsing
from xicm.core.contracts.types import KeyAction

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


# ------------------------------------------------------------------ X-ICM's reading (policy.parse_fallback)
def test_xicm_reading_keeps_seven_integer_groups_without_a_range_check():
    actions, fallback = parsing.parse_actions_xicm("[[10, 20, 30, 0, 36, 72, 1], [1, 2], [120, 5, 5, 80, 0, 0, 0]]", WS)
    assert fallback is None and len(actions) == 2  # [1, 2] is skipped: integers, not 7 of them
    assert actions[1].position[0] > WS[1][0] and actions[1].gripper_open is False  # off the grid: refused when executed


def test_xicm_reading_falls_back_to_its_default_actions():
    default = encoding.ints_to_action(parsing.XICM_DEFAULT_ACTION, WS)
    many, why = parsing.parse_actions_xicm("[[10, 20, 30, 0, 36, 0, 1], [0.3, 0.2]]", WS)
    assert many == [default] * parsing.MAX_ACTIONS and "not an integer" in why  # any non-integer item, in any group
    echoed, why = parsing.parse_actions_xicm("[7-dim action_1, 7-dim action_2]", WS)
    assert echoed == [default] * parsing.MAX_ACTIONS
    for text in ("I would move the arm to the drawer.", "", None, "[ , ]"):
        one, why = parsing.parse_actions_xicm(text, WS)
        assert one == [default] and "one default action" in why, text


def test_later_action_lists_are_read_up_to_26_actions_as_xicm_reads_the_whole_reply():
    """X-ICM's regex runs over the whole reply and its agent keeps the first 26 actions; every
    reading here does the same when the LLM returns the whole reply (stop_at_action_list: false)."""
    first = "[" + ", ".join(f"[{i}, 1, 2, 0, 36, 36, 1]" for i in range(20)) + "]"
    later = "[" + ", ".join(f"[{i}, 9, 9, 0, 36, 36, 0]" for i in range(20, 30)) + "]"
    reply = f"{first}\nThen:\n{later}"
    expected = [i for i in range(20)] + [20, 21, 22, 23, 24, 25]
    for actions in (
        parsing.parse_actions(reply, WS),
        parsing.parse_actions(reply, WS, partial=True),
        parsing.parse_actions_xicm(reply, WS)[0],
    ):
        assert len(actions) == parsing.MAX_ACTIONS == 26
        assert [encoding.position_to_voxel(a.position, WS)[0] for a in actions] == expected
        assert [a.gripper_open for a in actions[19:21]] == [True, False]


def test_first_list_only_keeps_what_stop_at_action_list_leaves():
    from xicm.plugins.llms.stopping import first_list_only

    reply = "Plan: [[1, 2, 3, 0, 36, 36, 1]] and again [[4, 5, 6, 0, 36, 36, 0]]"
    assert first_list_only(reply) == "Plan: [[1, 2, 3, 0, 36, 36, 1]]"
    assert first_list_only("[1, 2, 3, 0, 36, 36, 1] no outer list") == "[1, 2, 3, 0, 36, 36, 1] no outer list"
    assert len(parsing.parse_actions(first_list_only(reply), WS)) == 1 and len(parsing.parse_actions(reply, WS)) == 2
