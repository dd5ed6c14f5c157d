"""The paired comparison of two runs (xicm-report --paired): counts on common episodes, McNemar."""

import pytest
from scipy.stats import binomtest

from xicm.report.paired import mcnemar_exact, paired_comparison, paired_markdown


def row(task, seed, episode, success):
    return {"task": task, "seed": seed, "episode": episode, "success": success}


@pytest.mark.parametrize("only_a,only_b", [(0, 0), (1, 0), (7, 2), (3, 12), (20, 20), (40, 11)])
def test_mcnemar_is_scipys_exact_binomial_test(only_a, only_b):
    expected = 1.0 if only_a + only_b == 0 else binomtest(only_a, only_a + only_b, 0.5).pvalue
    assert mcnemar_exact(only_a, only_b) == pytest.approx(expected)


def test_only_common_episodes_are_compared_per_task():
    a = [row("t1", 0, 0, True), row("t1", 0, 1, True), row("t2", 0, 0, False), row("t2", 1, 0, True)]
    b = [row("t1", 0, 0, True), row("t1", 0, 1, False), row("t2", 0, 0, True), row("t3", 0, 0, True)]
    result = paired_comparison(a, b)
    assert (result["n"], result["a"], result["b"], result["only_a"], result["only_b"]) == (3, 2, 2, 1, 1)
    assert result["tasks"]["t1"] == {"n": 2, "a": 2, "b": 1, "only_a": 1, "only_b": 0}
    assert (result["only_in_a"], result["only_in_b"]) == (1, 1)
    text = paired_markdown(result, "A", "B")
    assert "| **all** | 3 | 2 (66.7 %) | 2 (66.7 %) | 1 | 1 |" in text and "p = 1 (two-sided)" in text


def test_paired_command_needs_two_runs(capsys):
    from xicm.report.cli import main as report_main

    with pytest.raises(SystemExit) as done:
        report_main(["--paired", "only_one_run"])
    assert done.value.code == 2
    assert "--paired compares two runs, not 1: xicm-report --paired RUN_A RUN_B" in capsys.readouterr().err


def test_episode_range_narrows_the_comparison():
    from xicm.report.paired import episode_range

    a = [row("t1", 0, e, e >= 2) for e in range(4)]
    b = [row("t1", 0, e, e == 0) for e in range(4)]
    result = paired_comparison(a, b, episodes=episode_range("2:4"))
    assert (result["n"], result["a"], result["b"], result["only_a"], result["only_b"]) == (2, 2, 0, 2, 0)
    assert "Paired over 2 common episodes, episodes 2-3 only" in paired_markdown(result, "A", "B")
    assert paired_comparison(a, b)["n"] == 4


@pytest.mark.parametrize("text", ["15", "25:15", "3:3", "a:b", "1.5:3", ":", "\u00b2:5"])
def test_a_bad_episode_range_is_one_sentence(text, capsys):
    from xicm.report.cli import main as report_main

    with pytest.raises(SystemExit) as done:
        report_main(["--paired", "run_a", "run_b", "--episodes", text])
    assert done.value.code == 2
    assert "is not an episode range FIRST:STOP" in capsys.readouterr().err


def test_episode_range_needs_paired(capsys):
    from xicm.report.cli import main as report_main

    with pytest.raises(SystemExit) as done:
        report_main(["some_run", "--episodes", "0:5"])
    assert done.value.code == 2 and "--episodes narrows a paired comparison" in capsys.readouterr().err
