"""A pytest plugin (loaded by conftest.py): with XICM_STRICT_SKIPS=1 or CI=true, a skipped test,
or a test file skipped at import, fails instead.

scripts/test.sh installs every extra (`xicm[all]`), chromium, FFmpeg and llama-server's compilers
before it runs the suite, so there a skip means a broken install (an `importorskip` of torch that finds
none), not an optional part left out. Only skips that name a platform the test command cannot
provide stay skips (PLATFORM_SKIPS). Without the variable, skips stay skips: a developer
without an extra still runs the rest."""

from __future__ import annotations

import os

import pytest

#: skip reasons (substrings) that stay skips under the strict rule: what scripts/test.sh cannot install
PLATFORM_SKIPS = (
    "needs Linux /proc",  # test_shared_llm_server: telling client processes apart
    "no python3.11 on PATH",  # test_export: the lerobot environment is built from the system's python3.11
)


def strict() -> bool:
    return os.environ.get("XICM_STRICT_SKIPS") == "1" or os.environ.get("CI", "").lower() == "true"


def skip_reason(report) -> str:
    longrepr = report.longrepr
    if isinstance(longrepr, tuple) and len(longrepr) == 3:
        return str(longrepr[2])
    return str(longrepr)


def forbidden(report) -> str | None:
    """The sentence to fail with when this skip is not allowed, else None."""
    if not (report.skipped and strict()) or hasattr(report, "wasxfail"):
        return None
    reason = skip_reason(report)
    if any(allowed in reason for allowed in PLATFORM_SKIPS):
        return None
    return (f"skipped under XICM_STRICT_SKIPS=1/CI=true, where the test command installed everything it needs "
            f"(a broken install?): {reason}")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    report = outcome.get_result()
    sentence = forbidden(report)
    if sentence:
        report.outcome, report.longrepr = "failed", sentence


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector):
    outcome = yield
    report = outcome.get_result()
    sentence = forbidden(report)
    if sentence:
        report.outcome, report.longrepr = "failed", sentence
