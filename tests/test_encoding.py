import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from xicm.core import encoding
from xicm.core.types import KeyAction, Trajectory

WS = ((-0.3, -0.5, 0.6), (0.7, 0.5, 1.6))  # upstream AGNOSTOS box: 1 cm voxels


def test_voxel_is_one_centimetre_and_decodes_to_the_centre():
    assert encoding.position_to_voxel((-0.3, -0.5, 0.6), WS) == (0, 0, 0)
    assert encoding.position_to_voxel((0.2049, 0.0, 1.1), WS) == (50, 50, 50)
    assert encoding.voxel_to_position((50, 50, 50), WS) == pytest.approx((0.205, 0.005, 1.105))


def test_positions_outside_the_box_clip_to_the_border():
    assert encoding.position_to_voxel((5.0, -5.0, 0.0), WS) == (99, 0, 0)


def test_rotation_bins_follow_the_agnostos_rule():
    # identity -> euler (0,0,0) -> (0+180)/5 = 36 per axis
    assert encoding.quat_to_bins((1, 0, 0, 0)) == (36, 36, 36)
    # gripper pointing down: 180 deg about x -> bin 72 wraps to 0
    x, y, z, w = Rotation.from_euler("xyz", [180, 0, 90], degrees=True).as_quat()
    assert encoding.quat_to_bins((w, x, y, z)) == (0, 36, 54)
    # q and -q are the same rotation and give the same bins
    assert encoding.quat_to_bins((-w, -x, -y, -z)) == (0, 36, 54)


@pytest.mark.parametrize("seed", range(20))
def test_rotation_round_trip_within_half_a_bin(seed):
    rot = Rotation.random(random_state=seed)
    x, y, z, w = rot.as_quat()
    back = encoding.bins_to_quat(encoding.quat_to_bins((w, x, y, z)))
    assert back[0] >= 0
    bx, by, bz, bw = back[1], back[2], back[3], back[0]
    angle = (Rotation.from_quat([bx, by, bz, bw]) * rot.inv()).magnitude()
    # three axes each off by <= 2.5 degrees
    assert np.degrees(angle) <= 2.5 * np.sqrt(3) + 1e-6


def test_action_round_trip_and_text():
    action = KeyAction((0.1234, -0.2, 0.95), (0.0, 1.0, 0.0, 0.0), True)
    ints = encoding.action_to_ints(action, WS)
    # 180 degrees about x: euler (180, 0, 0) -> bins (72 -> 0, 36, 36)
    assert ints == [42, 30, 35, 0, 36, 36, 1]
    assert all(isinstance(v, int) for v in ints)
    again = encoding.action_to_ints(encoding.ints_to_action(ints, WS), WS)
    assert again == ints
    assert encoding.format_actions([action], WS) == "[" + encoding.format_ints(ints) + "]"
    assert encoding.format_objects({"red button": (0.2049, 0.0, 1.1)}, WS) == "red button [50, 50, 50]"


def test_ints_to_action_rejects_wrong_length():
    with pytest.raises(ValueError, match="7 integers"):
        encoding.ints_to_action([1, 2, 3], WS)


def _trajectory(vel_rows, grip):
    n = len(grip)
    return Trajectory(
        joint_positions=np.zeros((n, 7)),
        joint_velocities=np.asarray(vel_rows, float),
        gripper_open=np.asarray(grip, bool),
        ee_poses=np.tile([0.0, 0, 1, 1, 0, 0, 0], (n, 1)) + np.arange(n)[:, None] * [1, 0, 0, 0, 0, 0, 0],
        success=True,
    )


def test_keyframes_at_stops_gripper_changes_and_the_end():
    moving, still = [0.5] * 7, [0.0] * 7
    # frames: 0-4 move, 5-9 still (a stop), 10-12 move, 13 gripper closes, 14-19 move, 20 last
    vel = [moving] * 5 + [still] * 5 + [moving] * 3 + [still] + [moving] * 6 + [still]
    grip = [True] * 13 + [False] * 8
    keys = encoding.keyframe_indices(vel, grip)
    assert keys == [5, 13, 20]
    actions = encoding.key_actions_from_trajectory(_trajectory(vel, grip))
    assert [a.position[0] for a in actions] == [5.0, 13.0, 20.0]
    assert [a.gripper_open for a in actions] == [True, False, False]


def test_a_long_stop_counts_once_per_four_frames():
    vel = [[0.0] * 7] * 12
    grip = [True] * 12
    assert encoding.keyframe_indices(vel, grip) == [2, 7, 11]


def test_adjacent_last_keyframes_drop_the_second_to_last():
    moving, still = [0.5] * 7, [0.0] * 7
    vel = [moving] * 6 + [still] + [moving]
    grip = [True] * 6 + [False, False]
    # gripper change at 6 and last frame 7 are adjacent -> keep only 7
    assert encoding.keyframe_indices(vel, grip) == [7]
