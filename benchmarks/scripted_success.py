"""Success of the SAPIEN scripted demonstrators, and of replaying their key actions.

For every task and seed: reset, run the scripted demonstrator, read the key actions off the
recorded trajectory with the AGNOSTOS key-frame rule, quantise them to the 1 cm / 5 degree
text grid, reset the same episode and execute them. Physics only (no rendering).

    python benchmarks/scripted_success.py [--seeds 50] [--first-seed 0] [--grasp attach|friction]
        [--success-check per_action|per_frame]
        [--scenes ours|rlbench] [--robot ours|rlbench] [--gripper-after-success]
        [--tasks open_drawer push_buttons ...]

The paper settings (src/xicm/conf/simulator/sapien_paper.yaml): --scenes rlbench --robot rlbench
--success-check per_frame --gripper-after-success.

With --scenes rlbench each scene is redrawn until the demonstrator solves it; the draws
column gives the mean number of draws per accepted scene and how many seeds had none solvable;
s/demo then includes the redraws' demonstrations.
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def main() -> None:
    from xicm.plugins.simulators.sapien.replay import demo_key_actions, replay
    from xicm.core.contracts.errors import EpisodeFailure
    from xicm.core.assembly.plugins import get_registry

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=50, help="seeds per task (episode 0 of seeds first-seed .. first-seed+N-1)")
    parser.add_argument("--tasks", nargs="*", default=None, help="tasks to run (default: all)")
    parser.add_argument("--no-replay", action="store_true", help="only run the demonstrators")
    parser.add_argument("--fixed-variation", action="store_true", help="always variation 0")
    parser.add_argument("--physics-hz", type=float, default=200.0)
    parser.add_argument("--grasp", choices=("attach", "friction"), default="attach", help="simulator.grasp mode")
    parser.add_argument("--success-check", choices=("per_action", "per_frame"), default="per_action")
    parser.add_argument("--scenes", choices=("ours", "rlbench"), default="ours", help="simulator.scenes")
    parser.add_argument("--robot", choices=("ours", "rlbench"), default="ours", help="simulator.robot")
    parser.add_argument("--gripper-after-success", action="store_true", help="simulator.gripper_after_success")
    parser.add_argument("--first-seed", type=int, default=0, help="first seed (to run a range in chunks)")
    args = parser.parse_args()

    options = {
        "name": "sapien",
        "render": False,
        "physics_hz": args.physics_hz,
        "grasp": args.grasp,
        "success_check": args.success_check,
        "scenes": args.scenes,
        "robot": args.robot,
        "gripper_after_success": args.gripper_after_success,
    }
    sim = get_registry().create_simulator(options)
    sim.sample_variations = not args.fixed_variation  # what benchmark.variations sets in a run
    tasks = args.tasks or sim.task_names()
    print(f"{'task':<18} {'demo ok':>9} {'replay ok':>10} {'raw replay':>11} {'frames':>7} {'keys':>5} {'s/demo':>7} {'draws':>11}")
    for task in tasks:
        demo_ok = replay_ok = raw_ok = 0
        frames, keys, secs = [], [], []
        failures, draws, unsolvable = [], [], 0
        for seed in range(args.first_seed, args.first_seed + args.seeds):
            t0 = time.perf_counter()
            try:
                sim.reset_state(task, seed, 0)
            except EpisodeFailure as failure:  # scenes: rlbench, no draw solvable
                unsolvable += 1
                failures.append(f"s{seed}: {failure}")
                continue
            draws.append(sim.scene_draw + 1)
            traj = sim.demonstrate()
            secs.append(time.perf_counter() - t0)
            demo_ok += traj.success
            frames.append(len(traj.gripper_open))
            if not traj.success:
                failures.append(f"s{seed}: demo ({sim.last_demo_error or 'not solved'})")
            if args.no_replay:
                continue
            actions = demo_key_actions(traj, sim.workspace)
            keys.append(len(actions))
            ok, err = replay(sim, task, seed, 0, actions)
            replay_ok += ok
            if traj.success and not ok:
                failures.append(f"s{seed}: replay ({err or 'not solved'})")
            ok_raw, _ = replay(sim, task, seed, 0, demo_key_actions(traj))
            raw_ok += ok_raw
        n = args.seeds
        rep = "-" if args.no_replay else f"{replay_ok}/{n}"
        raw = "-" if args.no_replay else f"{raw_ok}/{n}"
        mean_keys = f"{np.mean(keys):.1f}" if keys else "-"
        print(f"{task:<18} {demo_ok:>4}/{n:<4} {rep:>10} {raw:>11} {np.mean(frames):>7.1f} {mean_keys:>5} {np.mean(secs):>7.2f} {np.mean(draws) if draws else 0:>5.2f} ({unsolvable})")
        for line in failures:
            print(f"    {line}")
    sim.close()


if __name__ == "__main__":
    main()
