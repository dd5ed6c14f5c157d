"""Where the time of one collected demo goes: physics, rendering, IK, HDF5 and our own code.

    python benchmarks/profile_demo.py --demos 3 --tasks open_drawer,stack_blocks

Profiles `xicm.core.execution.collect.record_episode` (reset, first observation, scripted demo, last
observation, detection) plus writing the demo, with cProfile, and attributes the time spent
inside the SAPIEN calls that do the work: Scene.step (physics), update_render and
take_picture/get_picture (rendering), compute_inverse_kinematics (IK), h5py (writing).
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import tempfile
import time
from pathlib import Path

CATEGORIES = {
    "physics": ("step",),  # PhysxScene/Scene.step
    "rendering": ("update_render", "take_picture", "get_picture"),
    "IK": ("compute_inverse_kinematics",),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--demos", type=int, default=3, help="demos per task")
    ap.add_argument("--tasks", default="open_drawer,push_buttons,stack_blocks,place_cups,close_microwave")
    args = ap.parse_args()

    from xicm.core.execution.collect import record_episode
    from xicm.core.results.dataset import DemoWriter
    from xicm.core.assembly.plugins import get_registry

    reg = get_registry()
    sim = reg.create_simulator({"name": "sapien"})
    detector = reg.create("detector", {"name": "oracle"})
    tasks = args.tasks.split(",")
    sim.reset(tasks[0], 0, 999)  # the first render compiles shaders: keep it out of the profile
    with tempfile.TemporaryDirectory() as tmp, DemoWriter(Path(tmp) / "pool.h5", sim.workspace) as writer:
        profiler = cProfile.Profile()
        start = time.perf_counter()
        profiler.enable()
        n = 0
        for task in tasks:
            for episode in range(args.demos):
                demo, _ = record_episode(sim, detector, task, 0, episode, "front")
                writer.write(demo)
                n += 1
        profiler.disable()
        wall = time.perf_counter() - start
    sim.close()

    stats = pstats.Stats(profiler)
    spent = {k: 0.0 for k in (*CATEGORIES, "HDF5")}
    for (filename, _line, func), (_cc, _nc, _tt, cumulative, _callers) in stats.stats.items():
        for category, names in CATEGORIES.items():
            # SAPIEN's C methods appear as filename '~', func '<built-in method sapien.pysapien.step>'
            if filename == "~" and "sapien" in func and any(func.endswith(f".{name}>") for name in names):
                spent[category] += cumulative
        if "h5py" in filename and func in ("write", "create_dataset", "__setitem__"):
            spent["HDF5"] += cumulative
    print(f"{n} demos of {', '.join(tasks)} in {wall:.2f} s: {n / wall:.2f} demos/s (profiled, so a little slower)")
    print("| part | s | share |\n|---|---:|---:|")
    for k, v in spent.items():
        print(f"| {k} | {v:.2f} | {100 * v / wall:.0f}% |")
    rest = wall - sum(spent.values())
    print(f"| our code + Python (rest) | {rest:.2f} | {100 * rest / wall:.0f}% |")


if __name__ == "__main__":
    main()
