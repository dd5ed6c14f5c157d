"""Waiting for an xicm-serve-policy subprocess to open its port."""

import subprocess

import pytest


def wait_for_serving(server: subprocess.Popen, policy: str) -> None:
    """Read the server's output (stdout, text) until it says it serves `policy`; fail the test if it exits first."""
    for line in server.stdout:
        if f"serving policy '{policy}'" in line:
            return
    pytest.fail("xicm-serve-policy exited before serving")
