"""Episodes per minute with envs = 1, 2, 4 (simulators in worker processes, stepped in lockstep),
measured side by side in one run, for the in-process oracle, for the oracle served by
xicm-serve-policy over a websocket on 127.0.0.1 (policy=remote), and for a LeRobot checkpoint
served by xicm-serve-lerobot with --max-batch equal to envs (one forward pass per lockstep round).

    python benchmarks/bench_envs.py --envs 1 2 4 --episodes 8
    python benchmarks/bench_envs.py --policies served --envs 1 2
    python benchmarks/bench_envs.py --policies lerobot --checkpoint runs/act_seen/checkpoints/004000/pretrained_model

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
    return wait_for_port(subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True))


def start_lerobot_server(checkpoint: str, max_batch: int) -> tuple[subprocess.Popen, int]:
    cmd = [str(Path(sys.executable).parent / "xicm-serve-lerobot"), checkpoint, "--port", "0",
           "--control-mode", "joint_pos", "--max-batch", str(max_batch)]
    return wait_for_port(subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True))


def wait_for_port(server: subprocess.Popen) -> tuple[subprocess.Popen, int]:
    for line in server.stdout:
        if line.startswith("serving "):  # "serving <what> ... on ws://HOST:PORT"
            return server, int(line.split("ws://")[1].split()[0].rsplit(":", 1)[1])
    raise RuntimeError(f"the server ({' '.join(server.args[:2])}) exited before serving")


#: policy=remote mapped onto an xicm-export checkpoint's features (src/xicm/conf/experiment/vla_baseline.yaml)
LEROBOT_CLIENT = [
    "policy=remote", "policy.timeout_s=300", "policy.control_mode=joint_pos", "simulator.control_mode=joint_pos",
    "simulator.cameras=[front,wrist]", "policy.images={front: observation.images.front, wrist: observation.images.wrist}",
    "policy.state_key=observation.state", "policy.state=[joint_positions,gripper_width,tcp_pose,gripper_open]",
    "policy.prompt_key=task", "policy.chunk_steps_to_execute=10",
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--envs", type=int, nargs="+", default=[1, 2, 4])
    ap.add_argument("--episodes", type=int, default=8, help="episodes per configuration")
    ap.add_argument("--tasks", default="open_drawer,push_buttons")
    ap.add_argument("--image-size", type=int, default=64)
    ap.add_argument("--policies", nargs="+", default=["oracle", "served"], choices=["oracle", "served", "lerobot"])
    ap.add_argument("--checkpoint", help="a LeRobot pretrained_model folder trained on an xicm-export (for --policies lerobot)")
    args = ap.parse_args()
    if "lerobot" in args.policies and not args.checkpoint:
        ap.error("--policies lerobot needs --checkpoint")

    from xicm.core.execution.batched_envs import BatchedEnvs

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
            cfg = compose_cfg(overrides) if policy != "lerobot" else None  # lerobot: per envs, below
            base = None
            for n in args.envs:
                if policy == "lerobot":  # a server batching up to n requests per forward pass
                    server, port = start_lerobot_server(args.checkpoint, n)
                    cfg = compose_cfg([*LEROBOT_CLIENT, f"policy.port={port}", *common])
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
                if policy == "lerobot":
                    server.terminate()
                    server.wait(timeout=60)
                    server = None
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
    for policy in args.policies:
        same = len({tuple(v) for (p, _), v in outcomes.items() if p == policy}) == 1
        print(f"{policy}: same episode outcomes (success, steps, error) at every envs: {same}")


if __name__ == "__main__":
    main()
