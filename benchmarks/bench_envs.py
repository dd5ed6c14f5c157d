"""Episodes per minute with envs = 1, 2, 4 (simulators in worker processes, stepped in lockstep),
measured side by side in one run, for the in-process oracle and for the oracle served by
xicm-serve-policy over a websocket on 127.0.0.1 (policy=remote).

    python benchmarks/bench_envs.py --envs 1 2 4 --episodes 8
    python benchmarks/bench_envs.py --policies served --envs 1 2

Building the environments (one process each, first render included) is timed apart from the
episodes. Every configuration runs the same (task, seed, episode) keys; their results are
checked to be the same.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

from hydra import compose, initialize_config_module


def compose_cfg(overrides):
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        cfg = compose("config", overrides=overrides)
    cfg.run_name = cfg.tracking.group = "bench"  # their ${hydra:...} resolves only inside a Hydra app
    return cfg


def start_server(image_size: int, sessions: int) -> tuple[subprocess.Popen, int]:
    cmd = [str(Path(sys.executable).parent / "xicm-serve-policy"), "policy=oracle", "serve.port=0",
           f"serve.sessions={sessions}", f"simulator.image_size={image_size}"]
    server = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    for line in server.stdout:
        if "serving policy" in line:
            return server, int(line.split("ws://")[1].split()[0].rsplit(":", 1)[1])
    raise RuntimeError("xicm-serve-policy exited before serving")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--envs", type=int, nargs="+", default=[1, 2, 4])
    ap.add_argument("--episodes", type=int, default=8, help="episodes per configuration")
    ap.add_argument("--tasks", default="open_drawer,push_buttons")
    ap.add_argument("--image-size", type=int, default=64)
    ap.add_argument("--policies", nargs="+", default=["oracle", "served"], choices=["oracle", "served"])
    args = ap.parse_args()

    from xicm.core.batched_envs import BatchedEnvs

    tasks = args.tasks.split(",")
    keys = [(tasks[i % len(tasks)], 0, i) for i in range(args.episodes)]
    common = [f"simulator.image_size={args.image_size}", f"benchmark.tasks=[{args.tasks}]"]
    server, rows, outcomes = None, [], {}
    try:
        for policy in args.policies:
            overrides = ["policy=oracle", *common]
            if policy == "served":
                server, port = start_server(args.image_size, max(args.envs))
                overrides = ["policy=remote", f"policy.port={port}", "policy.timeout_s=120", *common]
            cfg = compose_cfg(overrides)
            base = None
            for n in args.envs:
                t0 = time.perf_counter()
                envs = BatchedEnvs(cfg, n, {"max_steps": int(cfg.max_steps)}, keys)
                built = time.perf_counter() - t0
                t0 = time.perf_counter()
                try:
                    results = [envs(*k) for k in keys]
                finally:
                    envs.close()
                seconds = time.perf_counter() - t0
                per_min = 60 * len(keys) / seconds
                base = base or per_min
                rows.append((policy, n, built, seconds, per_min, per_min / base, sum(r.success for r in results)))
                outcomes[(policy, n)] = [(r.success, r.steps, r.error_kind) for r in results]
                print(f"  {policy} envs={n}: {seconds:.1f} s for {len(keys)} episodes", flush=True)
            if server is not None:
                server.terminate()
                server.wait(timeout=60)
                server = None
    finally:
        if server is not None:
            server.kill()
    print(f"\n{len(keys)} episodes of {', '.join(tasks)} at {args.image_size} px per configuration\n")
    print("| policy | envs | build s | episodes s | episodes/min | ratio to envs=1 | successes |")
    print("|---|---|---|---|---|---|---|")
    for policy, n, built, seconds, per_min, ratio, ok in rows:
        print(f"| {policy} | {n} | {built:.1f} | {seconds:.1f} | {per_min:.1f} | {ratio:.2f} | {ok}/{len(keys)} |")
    same = len({tuple(v) for v in outcomes.values()}) == 1
    print(f"\nsame episode outcomes in every configuration: {same}")


if __name__ == "__main__":
    main()
