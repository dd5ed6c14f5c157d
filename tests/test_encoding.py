import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from xicm.core.text import encoding
from xicm.core.contracts.types import KeyAction, Trajectory

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


def test_xicm_rule_reads_the_end_of_the_trajectory_for_frames_0_and_1():
    moving, still = [0.5] * 7, [0.0] * 7
    # frame 1 and frame 5 still; the gripper stays open to the last frame
    vel = [moving, still, moving, moving, moving, still] + [moving] * 6
    grip = [True] * 12
    assert encoding.keyframe_indices(vel, grip) == [5, 11]
    # X-ICM: frame 1's i-2 is the last frame (open, as frame 1): frame 1 is a stop, and its
    # hold-off of 4 frames swallows the stop at frame 5
    assert encoding.keyframe_indices(vel, grip, rule="xicm") == [1, 11]
    actions = encoding.key_actions_from_trajectory(_trajectory(vel, grip), rule="xicm")
    assert [a.position[0] for a in actions] == [1.0, 11.0]


def test_xicm_rule_changes_nothing_when_the_wrapped_frames_differ():
    moving, still = [0.5] * 7, [0.0] * 7
    vel = [moving, still, moving, moving, moving, still] + [moving] * 6
    grip = [True] * 11 + [False]  # closed at the end: frame 1's wrapped neighbour differs
    assert encoding.keyframe_indices(vel, grip, rule="xicm") == encoding.keyframe_indices(vel, grip) == [5, 11]


def test_a_stop_at_frame_0_is_no_key_frame_but_holds_off_the_next_stops():
    still = [0.0] * 7
    vel, grip = [still] * 12, [True] * 12
    # ours: stops at 2 and 7; X-ICM: frame 0 stops (not a key frame), so 1-4 cannot; then 5 and 10
    # (10 dropped: next to the last frame)
    assert encoding.keyframe_indices(vel, grip) == [2, 7, 11]
    assert encoding.keyframe_indices(vel, grip, rule="xicm") == [5, 11]


def test_an_unknown_keyframe_rule_is_refused():
    with pytest.raises(ValueError, match="allowed: ours, xicm"):
        encoding.keyframe_indices([[0.0] * 7] * 3, [True] * 3, rule="peract")
