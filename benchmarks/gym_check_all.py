"""gymnasium.utils.env_checker.check_env on the Gymnasium env of every registered task.

Each task's env is built with RGB observations of one small camera (the checker resets and
steps it several times) and checked; warnings the checker raises are printed beside the task.

    python benchmarks/gym_check_all.py [--control-mode ee_delta] [--image-size 32] [--tasks ...]
"""

from __future__ import annotations

import argparse
import time
import warnings


def main() -> None:
    import gymnasium
    from gymnasium.utils.env_checker import check_env

    import xicm.vla
    from xicm.core.assembly.plugins import get_registry

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--control-mode", default="ee_delta")
    parser.add_argument("--obs-mode", default="rgb")
    parser.add_argument("--image-size", type=int, default=32)
    parser.add_argument("--tasks", nargs="*", default=None)
    args = parser.parse_args()

    tasks = args.tasks or list(get_registry().tasks(simulator="sapien"))
    passed = 0
    for task in tasks:
        t0 = time.perf_counter()
        env = gymnasium.make(
            xicm.vla.env_id(task), obs_mode=args.obs_mode, control_mode=args.control_mode,
            render_mode="rgb_array", cameras=["front"], image_size=args.image_size,
        )
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                check_env(env.unwrapped)
                verdict = "passed"
            except Exception as exc:  # noqa: BLE001 - report and go on with the next task
                verdict = f"FAILED: {type(exc).__name__}: {exc}"
        env.close()
        passed += verdict == "passed"
        notes = sorted({str(w.message).split("WARN: ")[-1][:80] for w in caught if "gymnasium" in w.filename})
        print(f"{xicm.vla.env_id(task):<42} {verdict} ({time.perf_counter() - t0:.1f} s){'  warnings: ' + '; '.join(notes) if notes else ''}", flush=True)
    print(f"check_env passed for {passed}/{len(tasks)} tasks (control_mode {args.control_mode}, obs_mode {args.obs_mode})")


if __name__ == "__main__":
    main()
