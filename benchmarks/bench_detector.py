"""Detector seconds per observation (all cameras), side by side, median over repeats.

    python benchmarks/bench_detector.py [--repeats 10] [--model PATH]

Detectors: oracle, noisy_oracle, and grounding_dino with the real checkpoint given by
--model, or (default) a tiny randomly initialised Grounding DINO of the same architecture
(the real weights are not on this machine: that timing is of the code path, not of the
real model). Observations: close_microwave, 5 cameras at 128x128.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=10)
    ap.add_argument("--model", default=None, help="a local Grounding DINO checkpoint (default: tiny random)")
    ap.add_argument("--task", default="close_microwave")
    args = ap.parse_args()

    import torch

    from xicm.core.assembly.plugins import get_registry

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the tiny model is a test helper
    from tiny_grounding_dino import build_tiny_grounding_dino

    torch.set_num_threads(2)
    reg = get_registry()
    sim = reg.create_simulator({"name": "sapien"})
    obs = sim.reset(args.task, 0, 0)
    names = list(obs.object_names)
    with tempfile.TemporaryDirectory() as tmp:
        model = args.model or str(build_tiny_grounding_dino(tmp, names))
        detectors = {
            "oracle": reg.create("detector", {"name": "oracle"}),
            "noisy_oracle": reg.create("detector", {"name": "noisy_oracle", "noise_cm": 2.0}),
            "grounding_dino" + ("" if args.model else " (tiny random)"): reg.create(
                "detector", {"name": "grounding_dino", "model": model, "cameras": None}
            ),
        }
        print(f"{args.task}: {len(obs.cameras)} cameras {next(iter(obs.cameras.values())).rgb.shape[:2]}, {len(names)} names")
        print("| detector | s per observation (median) | s per camera |\n|---|---:|---:|")
        for label, det in detectors.items():
            det.detect(obs, names)  # warm-up
            times = []
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                det.detect(obs, names)
                times.append(time.perf_counter() - t0)
            med = statistics.median(times)
            print(f"| {label} | {med:.4f} | {med / len(obs.cameras):.4f} |")
    sim.close()


if __name__ == "__main__":
    main()
