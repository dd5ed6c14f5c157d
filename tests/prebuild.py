"""A pytest plugin (loaded by conftest.py): the builds cached once per machine that some tests wait
for start in background processes as soon as the tests are collected, so they build while the rest
of the suite runs. The tests that need them run last (file_order.py) and wait on each build's file
lock; a build that is cached already returns at once, and one no selected test needs never starts.

    marker        what the tests wait for                                 from nothing, 2 cores
    llama_server  llama.cpp's llama-server (src/xicm/plugins/llms/build_llamacpp.sh)  ~7-12 min of compiling
    venv          the lerobot and openpi-client environments                ~10 min, mostly downloads

The builds run at the lowest CPU priority (nice 19), so the suite keeps the cores it uses; each
writes its output to <XICM_CACHE or ~/.cache/xicm>/prebuild-<marker>.log. A build outlives a
suite that ends before it (Ctrl-C stops both): it finishes into the cache, or, stopped, leaves
only its temp folder, which the next build replaces. Under pytest-xdist each worker that
collected such a test starts one; the file lock lets one build and the others return at once."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from xicm.plugins.llms.model_files import cache_root

#: marker -> the Python that builds what its tests wait for (run with tests/ as the working folder)
BUILDS = {
    "llama_server": "from xicm.plugins.llms.llamacpp_server import llama_server_binary; print(llama_server_binary())",
    "venv": "import isolated_envs; isolated_envs.build_all()",
}
_running: list[subprocess.Popen] = []  # held so that none is collected (and warned about) while it builds


def waits_for_a_build(item) -> bool:
    return any(item.get_closest_marker(marker) for marker in BUILDS)


def pytest_collection_finish(session):
    if session.config.option.collectonly:
        return
    needed = [marker for marker in BUILDS if any(item.get_closest_marker(marker) for item in session.items)]
    folder = cache_root()
    folder.mkdir(parents=True, exist_ok=True)
    for marker in needed:
        worker = os.environ.get("PYTEST_XDIST_WORKER", "")
        with open(folder / f"prebuild-{marker}{'-' + worker if worker else ''}.log", "w") as log:
            _running.append(subprocess.Popen(
                [sys.executable, "-c", BUILDS[marker]], cwd=Path(__file__).parent, stdout=log,
                stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, preexec_fn=lambda: os.nice(19),
            ))
