"""The suite's own plugins, the lanes' rules (lanes.py), the strict-skip rule (strict_skips.py),
the test order (file_order.py) and the cached builds started beside the suite (prebuild.py), each
run on a small suite of its own in a pytest run inside this one (pytester)."""

import pytest

SUITE = {
    "test_extra": "import pytest\npytest.importorskip('xicm_no_such_extra')\n\ndef test_uses_it():\n    pass\n",
    "test_fixture_skip": (
        "import pytest\n\n@pytest.fixture\ndef driver():\n    pytest.skip('chromedriver is not installed')\n\n"
        "def test_browser(driver):\n    pass\n"
    ),
    "test_platform": "import pytest\n\ndef test_proc():\n    pytest.skip('telling client processes apart needs Linux /proc')\n",
    "test_plain": "def test_runs():\n    pass\n",
}


@pytest.fixture
def suite(pytester, monkeypatch):
    for name in ("XICM_STRICT_SKIPS", "CI", "XICM_TEST_ORDER"):
        monkeypatch.delenv(name, raising=False)
    pytester.makepyfile(**SUITE)
    return pytester


def test_without_the_variable_skips_stay_skips(suite):
    result = suite.runpytest("-p", "strict_skips")
    result.assert_outcomes(passed=1, skipped=3)


@pytest.mark.parametrize("variable, value", [("XICM_STRICT_SKIPS", "1"), ("CI", "true")])
def test_strict_fails_a_missing_extra_and_a_skipping_fixture_but_not_a_platform_skip(suite, monkeypatch, variable, value):
    monkeypatch.setenv(variable, value)
    result = suite.runpytest("-p", "strict_skips", "--continue-on-collection-errors", "-rA")
    result.assert_outcomes(passed=1, skipped=1, errors=2)  # the file at collection, the test at its fixture
    result.stdout.fnmatch_lines([
        "*ERROR collecting test_extra.py*",
        "*skipped under XICM_STRICT_SKIPS=1/CI=true*could not import 'xicm_no_such_extra'*",
    ])
    result.stdout.fnmatch_lines(["*skipped under XICM_STRICT_SKIPS=1/CI=true*chromedriver is not installed*"])
    result.stdout.fnmatch_lines(["SKIPPED*needs Linux /proc*"])


def test_reverse_order_runs_the_files_backwards_each_in_its_own_order(pytester, monkeypatch):
    monkeypatch.delenv("XICM_TEST_ORDER", raising=False)
    pytester.makepyfile(test_a="def test_1():\n    pass\n\ndef test_2():\n    pass\n", test_b="def test_3():\n    pass\n")
    forward = pytester.runpytest("-p", "file_order", "--collect-only", "-q")
    forward.stdout.fnmatch_lines(["test_a.py::test_1", "test_a.py::test_2", "test_b.py::test_3"])
    backward = ["test_b.py::test_3", "test_a.py::test_1", "test_a.py::test_2"]
    pytester.runpytest("-p", "file_order", "--reverse-files", "--collect-only", "-q").stdout.fnmatch_lines(backward)
    monkeypatch.setenv("XICM_TEST_ORDER", "reverse")
    pytester.runpytest("-p", "file_order", "--collect-only", "-q").stdout.fnmatch_lines(backward)


def test_a_slow_test_must_say_what_makes_it_slow(pytester):
    pytester.makepyprojecttoml(
        '[tool.pytest.ini_options]\nmarkers = ["slow: not in the fast lane", "venv: builds an environment"]\n'
    )
    pytester.makepyfile(test_lane="import pytest\n\n@pytest.mark.slow\ndef test_unexplained():\n    pass\n")
    result = pytester.runpytest("-p", "lanes", "--strict-markers")
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    result.stderr.fnmatch_lines(["*slow tests must also carry what makes them slow (venv)*test_unexplained*"])
    pytester.makepyfile(test_lane="import pytest\n\n@pytest.mark.slow\n@pytest.mark.venv\ndef test_explained():\n    pass\n")
    items, _ = pytester.inline_genitems("-p", "lanes", "--strict-markers")
    from lanes import VENV_TIMEOUT_S

    assert [i.name for i in items] == ["test_explained"] and items[0].get_closest_marker("timeout").args == (VENV_TIMEOUT_S,)


WAITER = """import time
from pathlib import Path

import pytest

BUILT = Path({built!r})


@pytest.mark.venv
def test_waits_for_the_build():
    deadline = time.monotonic() + 60
    while not BUILT.exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert BUILT.read_text() == "built"


def test_plain():
    pass
"""


def test_a_build_the_selected_tests_wait_for_starts_at_collection_and_they_run_last(pytester, monkeypatch, tmp_path):
    import prebuild

    built = tmp_path / "built"
    monkeypatch.setenv("XICM_CACHE", str(tmp_path / "cache"))
    monkeypatch.delenv("XICM_TEST_ORDER", raising=False)
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)  # the inner run is no xdist worker, even when this one is
    monkeypatch.setitem(prebuild.BUILDS, "venv", f"open({str(built)!r}, 'w').write('built')")
    pytester.makepyfile(test_build=WAITER.format(built=str(built)))
    deselected = pytester.runpytest("-p", "prebuild", "-p", "file_order", "-m", "not venv")
    deselected.assert_outcomes(passed=1, deselected=1)
    assert not built.exists() and not (tmp_path / "cache" / "prebuild-venv.log").exists()  # nothing selected waits: nothing starts
    result = pytester.runpytest("-p", "prebuild", "-p", "file_order", "-v")
    result.assert_outcomes(passed=2)
    result.stdout.fnmatch_lines(["*test_plain PASSED*", "*test_waits_for_the_build PASSED*"])  # the waiting test last
    assert (tmp_path / "cache" / "prebuild-venv.log").exists()
