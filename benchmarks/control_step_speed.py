"""Seconds per control step of per-step control with rendering, by image size and camera count.

One control step = `step(action)` (frame_hz / control_hz frames of physics and task hooks)
plus rendering the chosen cameras' RGB, what a VLA policy or the Gymnasium env needs per step.
Every configuration is measured in this one process, side by side, holding the arm still on
one task (the physics cost barely depends on the action); the median over --steps steps.

    python benchmarks/control_step_speed.py [--sizes 128 224 256] [--cameras 1 2 5] [--steps 20]
"""

from __future__ import annotations

import argparse
import statistics
import time

CAMERA_SETS = {1: ["front"], 2: ["front", "wrist"], 5: ["front", "left_shoulder", "right_shoulder", "overhead", "wrist"]}


def seconds_per_step(registry, task: str, size: int, cameras: list[str] | None, steps: int, depth: bool) -> float:
    options = {"name": "sapien", "control_mode": "joint_delta", "depth": depth, "segmentation": depth}
    options.update({"render": False} if cameras is None else {"cameras": cameras, "image_size": size})
    sim = registry.create_simulator(options)
    try:
        sim.reset_state(task, 0, 0)
        hold = [0.0] * 7 + [1.0]
        for _ in range(3):  # the first pictures of a camera set are slow (shaders, buffers)
            sim.step(hold)
            if cameras is not None:
                sim.world.render(cameras)
        times = []
        for _ in range(steps):
            t0 = time.perf_counter()
            sim.step(hold)
            if cameras is not None:
                sim.world.render(cameras)
            times.append(time.perf_counter() - t0)
        return statistics.median(times)
    finally:
        sim.close()


def main() -> None:
    from xicm.core.assembly.plugins import get_registry

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[128, 224, 256])
    parser.add_argument("--cameras", type=int, nargs="+", default=[1, 2, 5], choices=sorted(CAMERA_SETS))
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--task", default="open_drawer")
    parser.add_argument("--depth", action="store_true", help="also read depth and segmentation pictures")
    args = parser.parse_args()

    registry = get_registry()
    physics = seconds_per_step(registry, args.task, 0, None, args.steps, False)
    print(f"control step without rendering: {physics * 1000:.1f} ms (median of {args.steps})")
    print(f"seconds per control step (median), RGB{' + depth + segmentation' if args.depth else ''}:")
    print(f"{'cameras':>8} " + " ".join(f"{f'{s} px':>9}" for s in args.sizes))
    for n in args.cameras:
        row = [seconds_per_step(registry, args.task, s, CAMERA_SETS[n], args.steps, args.depth) for s in args.sizes]
        print(f"{n:>8} " + " ".join(f"{v:>9.4f}" for v in row), flush=True)


if __name__ == "__main__":
    main()
