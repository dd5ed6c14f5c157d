"""A pytest plugin (loaded by conftest.py): the lanes' rules. Every `slow` test must also carry a
marker saying what makes it slow (one of the others pyproject.toml registers), and the tests that
wait for a build cached per machine (tests/prebuild.py) get a longer per-test timeout than
pyproject's `timeout`."""

from __future__ import annotations

import tomllib

import pytest

from prebuild import waits_for_a_build

#: per-test limit of the tests that wait for a cached build: a lerobot environment built from
#: nothing takes ~10 min and a test may train in it afterwards; llama-server compiles 7-12 min
VENV_TIMEOUT_S = 1800


def slow_reasons(pyproject) -> set[str]:
    """The markers pyproject.toml registers besides `slow`: what makes a slow test slow."""
    declared = tomllib.loads(pyproject.read_text())["tool"]["pytest"]["ini_options"]["markers"]
    return {line.split(":")[0].strip() for line in declared} - {"slow"}


def pytest_collection_modifyitems(config, items):
    reasons = slow_reasons(config.rootpath / "pyproject.toml")
    unexplained = [item.nodeid for item in items
                   if item.get_closest_marker("slow") and not reasons & {m.name for m in item.iter_markers()}]
    if unexplained:
        raise pytest.UsageError(f"slow tests must also carry what makes them slow ({', '.join(sorted(reasons))}): {unexplained}")
    for item in items:
        if waits_for_a_build(item) and not item.get_closest_marker("timeout"):
            item.add_marker(pytest.mark.timeout(VENV_TIMEOUT_S))
