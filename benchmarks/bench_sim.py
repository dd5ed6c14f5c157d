"""Speed of the SAPIEN simulator: physics steps/s, renders/s, resets and scripted demos/s.

    python benchmarks/bench_sim.py [--image-size 128] [--seconds 3]

Physics is measured with the arm moving (drive targets swept sinusoidally) so that nothing
sleeps; "bare" is robot + table, "task" adds the objects of each task.
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def physics_rate(sim, seconds: float) -> float:
    robot = sim.robot
    home = robot.arm_qpos()
    scene = sim.world.scene
    steps, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        phase = steps * scene.timestep
        robot.set_arm_target(home + 0.3 * np.sin(2.0 * phase + np.arange(7)))
        for _ in range(10):
            scene.step()
        steps += 10
    return steps / (time.perf_counter() - t0)


def main() -> None:
    from xicm.core.assembly.plugins import get_registry

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--image-size", type=int, default=128)
    ap.add_argument("--seconds", type=float, default=3.0, help="time per physics measurement")
    ap.add_argument("--renders", type=int, default=20)
    ap.add_argument("--demos", type=int, default=5, help="demos per task")
    args = ap.parse_args()

    registry = get_registry()  # imports sapien and the task classes: not part of "created in"
    t0 = time.perf_counter()
    sim = registry.create_simulator({"name": "sapien", "image_size": args.image_size})
    t_create = time.perf_counter() - t0
    tasks = sim.task_names()
    print(f"simulator created in {t_create:.2f} s (physics {sim.controller.physics_hz:.0f} Hz, frames {sim.controller.frame_hz:.0f} Hz)")

    bare = physics_rate(sim, args.seconds)  # no task loaded yet: robot + table
    print(f"physics, bare scene (robot + table): {bare:,.0f} steps/s ({bare / sim.controller.physics_hz:.1f}x real time)")
    for task in tasks:
        sim.reset_state(task, 0, 0)
        rate = physics_rate(sim, args.seconds)
        print(f"physics, {task} scene: {rate:,.0f} steps/s ({rate / sim.controller.physics_hz:.1f}x real time)")

    t0 = time.perf_counter()
    sim.reset(tasks[0], 0, 0)
    print(f"first reset + render (shader compile): {time.perf_counter() - t0:.2f} s")
    for task in tasks:
        sim.reset(task, 0, 0)
        t0 = time.perf_counter()
        for _ in range(args.renders):
            sim.observe()
        dt = (time.perf_counter() - t0) / args.renders
        print(f"observe() with {len(sim.world.cameras.cameras)} cameras at {args.image_size}px, {task}: {1 / dt:.1f} /s ({dt * 1000:.0f} ms)")
    cam = sim.world.cameras.cameras["front"]
    t0 = time.perf_counter()
    for _ in range(args.renders):
        sim.world.render(["front"])
    dt = (time.perf_counter() - t0) / args.renders
    print(f"one camera ({cam.name}) incl. update_render: {1 / dt:.1f} /s")

    for task in tasks:
        t_reset, t_demo, frames, ok = [], [], 0, 0
        for seed in range(args.demos):
            t0 = time.perf_counter()
            sim.reset_state(task, seed, 0)
            t_reset.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            traj = sim.demonstrate()
            t_demo.append(time.perf_counter() - t0)
            frames += len(traj.gripper_open)
            ok += traj.success
        total = sum(t_reset) + sum(t_demo)
        print(
            f"demos, {task}: {args.demos / total:.2f} demos/s (reset {np.mean(t_reset) * 1000:.0f} ms, "
            f"demo {np.mean(t_demo) * 1000:.0f} ms, {frames / args.demos:.0f} frames = "
            f"{frames / args.demos / sim.controller.frame_hz:.1f} s simulated, {ok}/{args.demos} ok)"
        )
    sim.close()


if __name__ == "__main__":
    main()
