"""Wire compatibility with openpi's own client (PyPI `openpi-client`, in its own environment: it
pins numpy < 2, so it is installed there with --no-deps beside what it imports)."""

import subprocess
from pathlib import Path

import numpy as np
import pytest

from isolated_envs import openpi_client_python
from xicm.serving.server import PolicyServer
from xicm.serving.wire import unpack

pytestmark = [pytest.mark.slow, pytest.mark.venv]


class Echo:
    def infer(self, obs):
        state = np.asarray(obs["observation/state"])
        image_sum = np.full(8, obs["observation/image"].astype(np.float32).sum(), dtype=np.float32)
        prompt_len = np.full(8, len(obs["prompt"]), dtype=np.float32)
        return {"actions": np.stack([state, image_sum, prompt_len])}


def test_openpis_client_talks_to_our_server_and_its_frames_unpack_here(tmp_path):
    python = openpi_client_python()
    server = PolicyServer(Echo(), port=0, metadata={"action_dim": 8}).start()
    try:
        out = tmp_path / "reply.npz"
        probe = Path(__file__).with_name("openpi_client_probe.py")
        done = subprocess.run([str(python), str(probe), "127.0.0.1", str(server.port), str(out)],
                              capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr[-3000:]
    finally:
        server.stop()
    got = np.load(out)
    state = np.linspace(0, 1, 8, dtype=np.float32)
    sent_image_sum = float(np.arange(4 * 4 * 3).sum())  # what the probe sent, as our server unpacked it
    expected = np.stack([state, np.full(8, sent_image_sum), np.full(8, len("close the box"))]).astype(np.float32)
    np.testing.assert_array_equal(got["actions"], expected)  # obs in, reply out, both ways
    assert got["actions"].dtype == np.float32 and int(got["metadata_action_dim"]) == 8
    frame = unpack(got["openpi_frame"].tobytes())  # a frame packed by openpi's own packer
    np.testing.assert_array_equal(frame["actions"], np.eye(3, 8))
    assert frame["step"] == 5 and frame["step"].dtype == np.int32


def test_openpis_client_with_its_api_key_gets_through_a_keyed_server(tmp_path, monkeypatch):
    python = openpi_client_python()
    monkeypatch.setenv("XICM_PROBE_KEY", "probe-key-123")
    server = PolicyServer(Echo(), port=0, metadata={"action_dim": 8}, api_key="probe-key-123").start()
    probe = [str(python), str(Path(__file__).with_name("openpi_client_probe.py")), "127.0.0.1", str(server.port)]
    try:
        keyed = subprocess.run([*probe, str(tmp_path / "keyed.npz"), "XICM_PROBE_KEY"], capture_output=True, text=True, timeout=120)
        monkeypatch.setenv("XICM_PROBE_KEY", "wrong")
        wrong = subprocess.run([*probe, str(tmp_path / "wrong.npz"), "XICM_PROBE_KEY"], capture_output=True, text=True, timeout=120)
    finally:
        server.stop()
    assert keyed.returncode == 0, keyed.stderr[-3000:]
    assert np.load(tmp_path / "keyed.npz")["actions"].shape == (3, 8)
    assert wrong.returncode != 0 and "HTTP 403" in wrong.stderr and not (tmp_path / "wrong.npz").exists()
