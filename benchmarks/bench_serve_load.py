"""Load on a real xicm-serve-policy (keyed, on 127.0.0.1): N concurrent clients each ask for the
first actions of episode after episode (a scene reset and the served policy's answer per request),
and the server's child processes, listening ports and open connections are counted before the
clients come and after they leave.

    python benchmarks/bench_serve_load.py [--clients 8] [--requests 10] [--sessions 8] [-- OVERRIDE ...]

With --sessions below --clients the server builds the missing sessions (a simulator process each)
while the clients wait, and closes them when they leave: the first requests' latency then holds
that build, and the counts after must still equal those before.
"""

from __future__ import annotations

import argparse
import os
import secrets
import sys
import threading
import time
from pathlib import Path

from xicm.serving.client import PolicyClient, server_uri
from xicm.serving.ports import ServerNotReady, free_port, server_counts, start_server, stop_process


def client_loop(uri: str, key: str, index: int, requests: int, task: str, latencies: list, failures: list) -> None:
    client = PolicyClient(uri, timeout_s=600, api_key=key)
    try:
        client.connect()
        for n in range(requests):
            start = time.perf_counter()
            reply = client.infer({"xicm/episode": {"task": task, "seed": index, "episode": n, "call": 0}})
            latencies.append((n, 1000 * (time.perf_counter() - start)))
            if not isinstance(reply, dict) or "actions" not in reply or "xicm/failure" in reply:
                failures.append(f"client {index} request {n}: {str(reply)[:200]}")
    except Exception as exc:  # noqa: BLE001 - reported below
        failures.append(f"client {index}: {type(exc).__name__}: {exc}")
    finally:
        client.close()


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(q / 100 * (len(ordered) - 1))))]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--clients", type=int, default=8)
    ap.add_argument("--requests", type=int, default=10, help="per client")
    ap.add_argument("--sessions", type=int, default=8, help="sessions the server builds at start (serve.sessions)")
    ap.add_argument("--task", default="push_buttons")
    ap.add_argument("overrides", nargs="*", help="more xicm-serve-policy overrides (default: policy=oracle simulator.image_size=32)")
    args = ap.parse_args()
    key = secrets.token_hex(16)
    port = free_port()
    overrides = args.overrides or ["policy=oracle", "simulator.image_size=32"]
    command = [str(Path(sys.executable).parent / "xicm-serve-policy"), *overrides, f"serve.port={port}", f"benchmark.tasks=[{args.task}]",
               f"serve.sessions={args.sessions}", f"serve.max_sessions={max(args.clients, args.sessions)}", "serve.api_key_env=XICM_BENCH_KEY"]
    t0 = time.monotonic()
    try:
        server, _ = start_server(command, "serving policy", env={**os.environ, "XICM_BENCH_KEY": key})
    except ServerNotReady as exc:
        sys.exit(str(exc))
    try:
        print(f"server up in {time.monotonic() - t0:.1f} s: {' '.join(overrides)}, {args.sessions} sessions built at start")
        before = server_counts(server.pid, port)
        latencies: list[tuple[int, float]] = []
        failures: list[str] = []
        uri = server_uri("127.0.0.1", port)
        threads = [threading.Thread(target=client_loop, args=(uri, key, i, args.requests, args.task, latencies, failures))
                   for i in range(args.clients)]
        t0 = time.monotonic()
        for t in threads:
            t.start()
        peak = before
        while any(t.is_alive() for t in threads):
            now = server_counts(server.pid, port)
            peak = {k: max(peak[k], now[k]) if k != "listening" else sorted(set(peak[k]) | set(now[k])) for k in now}
            time.sleep(0.2)
        wall = time.monotonic() - t0
        after = server_counts(server.pid, port)
        deadline = time.monotonic() + 60  # sessions built on need close a moment after their client leaves
        while after != before and time.monotonic() < deadline:
            time.sleep(0.5)
            after = server_counts(server.pid, port)
    finally:
        stop_process(server, timeout_s=60)
    all_ms = [ms for _, ms in latencies]
    steady = [ms for n, ms in latencies if n > 0]
    print(f"{args.clients} clients x {args.requests} requests in {wall:.1f} s ({len(latencies)} answered, {len(failures)} failed)")
    for name, values in (("all requests", all_ms), ("after each client's first", steady)):
        if values:
            print(f"  per-request latency, {name} ({len(values)}): p50 {percentile(values, 50):.0f} ms, "
                  f"p99 {percentile(values, 99):.0f} ms, max {max(values):.0f} ms")
    print(f"server before: {before}")
    print(f"server peak:   {peak}  (each count's maximum while the clients ran)")
    print(f"server after:  {after}  ({'equal' if after == before else 'NOT equal'} to before)")
    for failure in failures[:5]:
        print(f"  failure: {failure}")
    if failures or after != before:
        sys.exit(1)


if __name__ == "__main__":
    main()
