"""One OpenAI-compatible LLM server shared by the Ray-sharded simulator workers of one evaluation
(the vLLM-on-a-GPU-node set-up of docs/guides/serving.md, "One LLM server for many simulator workers"), with a scripted server on 127.0.0.1."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from test_llm_openai_compatible import FakeOpenAI

pytestmark = [pytest.mark.slow, pytest.mark.ray, pytest.mark.subprocess]

BIN = Path(sys.executable).parent
REPLY = "[[50, 50, 30, 0, 36, 0, 1]]"


def pid_of_client(client_port: int, server_port: int) -> int | None:
    """The process holding the client end of a TCP connection to 127.0.0.1:server_port (Linux /proc)."""
    inode = None
    with open("/proc/net/tcp") as table:
        for line in table.readlines()[1:]:
            fields = line.split()
            local_port, remote_port = (int(f.split(":")[1], 16) for f in fields[1:3])
            if (local_port, remote_port) == (client_port, server_port):
                inode = fields[9]
    if inode is None:
        return None
    target = f"socket:[{inode}]"
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            if any(os.readlink(f"/proc/{pid}/fd/{fd}") == target for fd in os.listdir(f"/proc/{pid}/fd")):
                return int(pid)
        except OSError:  # the process ended or is not ours to read
            continue
    return None


@pytest.fixture
def server():
    if not os.path.exists("/proc/net/tcp"):
        pytest.skip("telling client processes apart needs Linux /proc")
    fake = FakeOpenAI()
    fake.reply = REPLY
    fake.client_pids = []
    base = fake.server.RequestHandlerClass

    class RecordsClientPid(base):
        def do_POST(self):
            fake.client_pids.append(pid_of_client(self.client_address[1], fake.port))  # while the client waits
            super().do_POST()

    fake.server.RequestHandlerClass = RecordsClientPid
    yield fake
    fake.close()


def test_ray_workers_share_one_openai_server(server, smoke_pool, tmp_path):
    pool_path, _ = smoke_pool
    proc = subprocess.Popen(
        [
            str(BIN / "xicm-eval"), "llm=openai", f"llm.base_url={server.base_url}", "llm.model=test-model",
            "llm.retries=0", "llm.timeout_s=60", "llm_cache.enabled=false", "retriever=random", "policy.k=2",
            "benchmark=smoke", "episodes=2", "max_steps=2", f"pool_path={pool_path}",
            "shards.backend=ray", "shards.workers=2", "shards.cpus_per_worker=0.5",
            "hydra.run.dir=run", "progress=false", "tracking.mode=disabled",
        ],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )
    output, _ = proc.communicate(timeout=900)
    assert proc.returncode == 0, output[-4000:]

    rows = [json.loads(line) for line in (tmp_path / "run" / "episodes.jsonl").read_text().splitlines()]
    keys = [(r["task"], r["seed"], r["episode"]) for r in rows]
    assert sorted(keys) == sorted((t, 0, e) for t in ("open_drawer", "push_buttons", "close_microwave") for e in (0, 1))
    assert all(r["error_kind"] != "llm_error" and r["responses"] and set(r["responses"]) == {REPLY} for r in rows), rows
    completions = [req for req in server.requests if req["path"].endswith("/completions")]
    checks = [req for req in server.requests if req["path"] == "/v1/models"]
    assert sum(len(r["responses"]) for r in rows) == len(completions)
    assert all(req["body"]["model"] == "test-model" for req in completions)
    assert len(checks) == 2  # each Ray worker checked the server once, at start

    pids = set(server.client_pids)
    assert None not in pids and proc.pid not in pids  # the driver itself asks nothing
    assert len(pids) >= 2, f"all requests came from {pids}"
