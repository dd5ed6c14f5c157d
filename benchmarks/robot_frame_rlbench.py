"""Check simulator.robot: rlbench against RoboVerse's recordings made inside RLBench.

metasim-core 0.1.0 (PyPI; data only: downloaded, unpacked, never installed or imported) ships
RoboVerse's close_box trajectories recorded in RLBench: per episode the Panda's base pose, start
joints and per-frame joints, and the box's pose and lid joint. This prints the recorded base and
start joints, then poses our Panda URDF at the recorded base and joints, and the recorded box
URDF at its recorded pose and lid angle, on every frame where the lid moves: if the frame is
right, the hand stays on the lid while it pushes it shut. The mean distance from the nearest of
the hand's points (both fingers, the TCP) to the lid is printed for the recorded base and for
the base shifted by a few centimetres.

    python benchmarks/robot_frame_rlbench.py [--episodes 30] [--cache ~/.cache/xicm/metasim]
"""

from __future__ import annotations

import argparse
import gzip
import pickle
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np

WHEEL = "metasim-core==0.1.0"
TRAJ = "metasim/data/quick_start/trajs/rlbench/close_box/v2/franka_v2.pkl.gz"
BOX = "metasim/data/quick_start/assets/rlbench/close_box/box_base/urdf/box_base_unique.urdf"
LID_BOX = ([0.126009, 0.038258, -0.000070], (1.570772, 3.141586, -2.879811), [0.134, 0.175, 0.005])  # box_lid's collision box
ARM = [f"panda_joint{i}" for i in range(1, 8)] + ["panda_finger_joint1", "panda_finger_joint2"]
HAND = ("panda_leftfinger", "panda_rightfinger", "panda_hand_tcp")


def unpacked(cache: Path) -> Path:
    out = cache / "metasim_core-0.1.0"
    if not (out / TRAJ).exists():
        cache.mkdir(parents=True, exist_ok=True)
        subprocess.run([sys.executable, "-m", "pip", "download", "--no-deps", "-q", "-d", str(cache), WHEEL], check=True)
        with zipfile.ZipFile(next(cache.glob("metasim_core-0.1.0-*.whl"))) as z:
            z.extractall(out, [n for n in z.namelist() if n in (TRAJ, BOX)])
    return out


def main() -> None:
    import sapien
    from transforms3d.euler import euler2quat

    from xicm.plugins.simulators.sapien.robot import URDF
    from xicm.plugins.simulators.sapien.scene import ROBOT_PLACEMENTS, TABLE_TOP_Z

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=30)
    ap.add_argument("--cache", default=str(Path.home() / ".cache/xicm/metasim"))
    args = ap.parse_args()
    root = unpacked(Path(args.cache).expanduser())
    episodes = pickle.load(gzip.open(root / TRAJ, "rb"))["franka"]

    base = np.array([e["init_state"]["franka"]["pos"] for e in episodes])
    quat = np.array([e["init_state"]["franka"]["rot"] for e in episodes])
    start = np.array([[e["init_state"]["franka"]["dof_pos"][j] for j in ARM[:7]] for e in episodes])
    print(f"{len(episodes)} episodes; base position spread {np.ptp(base, axis=0).max():.1e} m, start joints spread {np.ptp(start, axis=0).max():.1e} rad")
    print(f"recorded base (z from the table top): {base[0].round(6).tolist()}, quaternion wxyz {quat[0].round(6).tolist()}")
    print(f"recorded start joints: {start.mean(0).round(4).tolist()}")
    ours = ROBOT_PLACEMENTS["rlbench"]
    print(f"simulator.robot=rlbench: base {list(ours.position)} (table top at {TABLE_TOP_Z}), start joints {list(ours.home_qpos)}")

    scene = sapien.Scene()
    loader = scene.create_urdf_loader()
    loader.fix_root_link = True
    panda = loader.load(str(URDF)).create_pinocchio_model()
    names = [link.name for link in loader.load(str(URDF)).get_links()]
    box_art = loader.load(str(root / BOX))
    box = box_art.create_pinocchio_model()
    lid = [link.name for link in box_art.get_links()].index("box_lid")
    lid_local = sapien.Pose(LID_BOX[0], euler2quat(*LID_BOX[1], "sxyz"))
    half = np.array(LID_BOX[2])

    frames = []  # (recorded base, hand points in the base frame, lid pose) while the lid moves
    for e in episodes[: args.episodes]:
        lid_q = np.array([s["box_base"]["dof_pos"]["box_joint"] for s in e["states"]])
        for t in np.where(np.abs(np.diff(lid_q)) > 0.005)[0][::3]:
            s = e["states"][t]
            panda.compute_forward_kinematics(np.array([s["franka"]["dof_pos"][j] for j in ARM]))
            box.compute_forward_kinematics(np.array([lid_q[t]]))
            lid_pose = sapien.Pose(s["box_base"]["pos"], s["box_base"]["rot"]) * box.get_link_pose(lid) * lid_local
            hand = [panda.get_link_pose(names.index(n)) for n in HAND]
            frames.append((sapien.Pose(s["franka"]["pos"], s["franka"]["rot"]), hand, lid_pose))

    def mean_gap(shift) -> float:
        gaps = []
        for b, hand, lid_pose in frames:
            moved = sapien.Pose(b.p + np.asarray(shift), b.q)
            points = [(lid_pose.inv() * moved * h).p for h in hand]
            gaps.append(min(float(np.linalg.norm(np.maximum(np.abs(p) - half, 0))) for p in points))
        return float(np.mean(gaps))

    print(f"\n{len(frames)} frames while the lid moves; mean distance from the hand to the lid:")
    print("| base | mean gap (mm) |\n|---|---|")
    for label, shift in [("as recorded", (0, 0, 0)), ("x -8 cm (ours is 8.2 cm further back)", (-0.08, 0, 0)),
                         ("x -4 cm", (-0.04, 0, 0)), ("x +4 cm", (0.04, 0, 0)), ("y -4 cm", (0, -0.04, 0)),
                         ("y +4 cm", (0, 0.04, 0)), ("z -4 cm", (0, 0, -0.04)), ("z +4 cm", (0, 0, 0.04))]:
        print(f"| {label} | {1000 * mean_gap(shift):.1f} |")


if __name__ == "__main__":
    main()
