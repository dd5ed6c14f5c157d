"""A pytest plugin (loaded by conftest.py): the order the tests run in.

- The tests that wait for a build cached per machine (tests/prebuild.py: llama-server, the
  isolated environments) run last, in their own order, so the builds have the rest of the
  suite's time to finish in the background.
- XICM_TEST_ORDER=reverse or --reverse-files runs the test files in reverse order, each file's
  tests in their own order, to show that no test depends on another file's having run first."""

from __future__ import annotations

import os

import pytest

from prebuild import waits_for_a_build


def pytest_addoption(parser):
    parser.addoption("--reverse-files", action="store_true", help="run the test files in reverse order (as XICM_TEST_ORDER=reverse)")


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config, items):
    if config.getoption("--reverse-files") or os.environ.get("XICM_TEST_ORDER") == "reverse":
        files: dict = {}
        for item in items:
            files.setdefault(item.path, []).append(item)
        items[:] = [item for path in reversed(list(files)) for item in files[path]]
    items.sort(key=waits_for_a_build)  # stable: False (runs now) before True (waits for a build)
