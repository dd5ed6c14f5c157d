"""src/xicm/core/execution/keyed_window.py: run ahead, hand back in key order (the window of envs=N and Ray shards)."""

import pytest

from xicm.core.execution.keyed_window import KeyedWindow

KEYS = [("t", 0, e) for e in range(6)]


def test_hands_out_keys_in_order_up_to_its_size_and_makes_room_as_results_are_taken():
    window = KeyedWindow(KEYS, 2)
    assert [window.take(), window.take(), window.take()] == [KEYS[0], KEYS[1], None]  # full
    window.done(KEYS[1], "r1")  # a later key finishing first still holds its place
    assert window.take() is None and window.is_ready(KEYS[1]) and not window.is_ready(KEYS[0])
    window.done(KEYS[0], "r0")
    assert window.pop(KEYS[0]) == "r0"
    assert window.take() == KEYS[2]
    assert window.pop(KEYS[1]) == "r1"
    with pytest.raises(KeyError):
        window.pop(KEYS[2])  # running, not ready


def test_a_key_asked_out_of_order_runs_at_once_past_the_size():
    window = KeyedWindow(KEYS, 1)
    assert window.take() == KEYS[0]
    assert window.take(KEYS[4]) == KEYS[4] and window.is_running(KEYS[4])
    window.done(KEYS[0], 0)
    window.pop(KEYS[0])
    assert window.take() is None  # KEYS[4] fills the window
    window.done(KEYS[4], 4)
    assert window.pop(KEYS[4]) == 4
    assert [window.take(), window.take()] == [KEYS[1], None]
    assert KEYS[4] not in window.queue  # never handed out twice


def test_keys_put_back_go_first_in_key_order_and_stop_ends_the_handing_out():
    window = KeyedWindow(KEYS, 4)
    taken = [window.take() for _ in range(4)]
    window.done(taken[1], "kept")
    window.put_back([taken[3], taken[0], taken[1]])  # taken[1] is done: its result stays
    assert window.is_ready(taken[1]) and not window.is_running(taken[0])
    assert list(window.queue) == [KEYS[0], KEYS[3], KEYS[4], KEYS[5]]
    window.stop()
    assert window.take() is None and window.is_running(KEYS[2])


def test_refuses_an_empty_window():
    with pytest.raises(ValueError, match="at least one key"):
        KeyedWindow(KEYS, 0)
