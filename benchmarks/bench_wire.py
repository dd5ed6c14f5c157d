"""Round-trip latency of one request over openpi's websocket protocol on 127.0.0.1 (xicm's
PolicyServer and PolicyClient), for a VLA-sized observation, against the server's own
infer time (here a chunk returned at once, so the figure is the protocol's cost).

    python benchmarks/bench_wire.py [--size 224] [--cameras 2] [--requests 200]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from xicm.serving.client import PolicyClient, server_uri
from xicm.serving.server import PolicyServer
from xicm.serving.wire import pack, unpack


class Chunk:
    def infer(self, obs):
        return {"actions": np.zeros((10, 8))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=224)
    ap.add_argument("--cameras", type=int, default=2)
    ap.add_argument("--requests", type=int, default=200)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    obs = {f"observation/image_{i}": rng.integers(0, 256, (args.size, args.size, 3), dtype=np.uint8) for i in range(args.cameras)}
    obs.update({"observation/state": rng.normal(size=16).astype(np.float32), "prompt": "push the red button"})
    frame = pack(obs)
    t0 = time.perf_counter()
    for _ in range(args.requests):
        unpack(pack(obs))
    codec_ms = 1000 * (time.perf_counter() - t0) / args.requests

    server = PolicyServer(Chunk(), port=0).start()
    client = PolicyClient(server_uri("127.0.0.1", server.port), timeout_s=30)
    client.connect()
    for _ in range(10):  # warm-up
        client.infer(obs)
    times = []
    for _ in range(args.requests):
        t0 = time.perf_counter()
        client.infer(obs)
        times.append(1000 * (time.perf_counter() - t0))
    client.close()
    server.stop()
    times.sort()
    print(f"request: {args.cameras} x {args.size} px RGB + 16-D state + prompt = {len(frame) / 1e6:.2f} MB per frame")
    print(f"pack + unpack of the request: {codec_ms:.2f} ms")
    print(f"round trip over 127.0.0.1 ({args.requests} requests): median {statistics.median(times):.2f} ms, "
          f"p90 {times[int(0.9 * len(times))]:.2f} ms, min {times[0]:.2f} ms")


if __name__ == "__main__":
    main()
