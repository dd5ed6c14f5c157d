"""build_llamacpp.sh takes the same lock as llm=llamacpp's own build (llamacpp_server.py,
fcntl.flock) unless LOCK=0: run by hand or by scripts/test.sh it waits while that lock is held, and
then leaves a binary built meanwhile as it is; with LOCK=0 (what llamacpp_server.py, holding the
lock, passes) it does not wait."""

import os
import subprocess
import time

from xicm.core.results.atomic import file_lock
from xicm.plugins.llms import llamacpp_server


def test_a_build_waits_for_the_lock_holder_and_keeps_what_it_built(tmp_path, monkeypatch):
    monkeypatch.setenv("XICM_CACHE", str(tmp_path))
    binary = llamacpp_server.cached_binary()
    assert binary.is_relative_to(tmp_path)
    lock = binary.parents[2] / ".build.lock"
    lock.parent.mkdir(parents=True)
    script = None
    try:
        with file_lock(lock):  # held before the script starts
            script = subprocess.Popen(["bash", str(llamacpp_server.BUILD_SCRIPT)], env={k: v for k, v in os.environ.items() if k != "LOCK"},
                                      stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
            time.sleep(1.0)
            assert script.poll() is None  # waiting on the lock, not downloading or building
            binary.parent.mkdir(parents=True)
            binary.write_text("#!/bin/sh\n")
            binary.chmod(0o755)
        out, err = script.communicate(timeout=30)
    finally:
        if script is not None and script.poll() is None:  # it did not wait: stop the download or build it began
            os.killpg(script.pid, 9)
            script.wait()
    assert script.returncode == 0, err
    assert out.strip() == str(binary) and binary.read_text() == "#!/bin/sh\n"
    assert not (binary.parents[2] / "sdist").exists()  # nothing was downloaded


def test_the_lock_holders_own_build_does_not_wait_on_its_lock(tmp_path, monkeypatch):
    monkeypatch.setenv("XICM_CACHE", str(tmp_path))
    lock = llamacpp_server.cached_binary().parents[2] / ".build.lock"
    lock.parent.mkdir(parents=True)
    with file_lock(lock):  # a missing sdist makes the build fail at once, once past the lock
        done = subprocess.run(["bash", str(llamacpp_server.BUILD_SCRIPT)], capture_output=True, text=True, timeout=30,
                              env={**os.environ, "LOCK": "0", "SDIST": str(tmp_path / "absent.tar.gz")})
    assert done.returncode != 0 and "absent.tar.gz" in done.stderr
