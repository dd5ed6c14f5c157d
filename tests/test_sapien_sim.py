"""SapienSimulator behaviour: seeded resets, success checks, scripted demos, replay, cameras.

Tests that render share the session's `sim`; those whose outcome is exact physics take a fresh
`physics_sim` each (conftest.py), so they pass in any order.
"""

import json
import subprocess
import sys

import numpy as np
import pytest

from xicm.core.text.parsing import MAX_ACTIONS
from xicm.core.assembly.plugins import get_registry
from xicm.core.contracts.types import KeyAction
from xicm.plugins.simulators.sapien.replay import demo_key_actions, replay

TASKS = list(get_registry().tasks(simulator="sapien"))  # every task registered for SAPIEN gets the generic tests
# Every set-up starts a new PhysX scene (SapienSimulator._build_world), so a seeded reset repeats
# bit for bit whatever the process simulated before. DISTINCT_TOL: what makes two scenes different.
DISTINCT_TOL = 1e-3


def scene_state(sim) -> np.ndarray:
    """Root poses and joint positions of every task articulation, and poses of free objects."""
    parts = []
    for art in sim.objects.articulations:
        pose = art.get_root_pose()
        parts.append(np.concatenate([pose.p, pose.q, art.get_qpos()]))
    for actor in sim.objects.actors:
        parts.append(np.concatenate([actor.pose.p, actor.pose.q]))
    return np.concatenate(parts)


# ------------------------------------------------------------------ seeding
@pytest.mark.parametrize("task", TASKS)
def test_seeded_reset_is_reproducible(sim, task):
    first = sim.reset(task, 7, 0)
    a = scene_state(sim)
    sim.reset_state(task, 8, 0)
    other_seed = scene_state(sim)
    sim.reset_state(task, 7, 1)
    other_episode = scene_state(sim)
    again = sim.reset(task, 7, 0)
    np.testing.assert_array_equal(a, scene_state(sim))
    assert first.instruction == again.instruction
    np.testing.assert_array_equal(first.cameras["front"].rgb, again.cameras["front"].rgb)
    assert not np.allclose(a, other_seed, atol=DISTINCT_TOL)
    assert not np.allclose(a, other_episode, atol=DISTINCT_TOL)


def test_same_seed_gives_the_same_scene_in_another_process(physics_sim):
    code = (
        "import json, numpy as np\n"
        "from xicm.core.assembly.plugins import get_registry\n"
        "sim = get_registry().create_simulator({'name': 'sapien', 'render': False})\n"
        "out = {}\n"
        f"for task in {TASKS!r}:\n"
        "    sim.reset_state(task, 7, 0)\n"
        "    out[task] = [a.get_root_pose().p.tolist() + a.get_root_pose().q.tolist() + a.get_qpos().tolist()"
        " for a in sim.objects.articulations]"
        " + [e.pose.p.tolist() + e.pose.q.tolist() for e in sim.objects.actors]\n"
        "print(json.dumps(out))\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    theirs = json.loads(run.stdout.strip().splitlines()[-1])
    for task in TASKS:
        physics_sim.reset_state(task, 7, 0)
        np.testing.assert_array_equal(np.concatenate(theirs[task]), scene_state(physics_sim), err_msg=task)


# ------------------------------------------------------------------ success checks
@pytest.mark.parametrize("task", TASKS)
def test_doing_nothing_is_not_a_success(sim, task):
    obs = sim.reset(task, 3, 0)
    assert not sim.is_success()
    outcome = sim.execute(obs.gripper)  # stay where it is
    assert outcome.ok and not outcome.success


@pytest.mark.parametrize("task", TASKS)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_scripted_demo_succeeds(physics_sim, task, seed):
    physics_sim.reset_state(task, seed, 0)
    traj = physics_sim.demonstrate()
    assert traj.success, physics_sim.last_demo_error
    n = len(traj.gripper_open)
    assert traj.joint_positions.shape == (n, 7) and traj.joint_velocities.shape == (n, 7)
    assert traj.ee_poses.shape == (n, 7) and traj.gripper_open.dtype == bool
    np.testing.assert_allclose(np.linalg.norm(traj.ee_poses[:, 3:], axis=1), 1.0, atol=1e-5)
    assert np.all(traj.ee_poses[:, 3] >= 0)
    assert np.max(np.abs(traj.joint_velocities[-1])) < 0.1  # the arm comes to rest at the end


def test_wrong_drawer_is_not_a_success(physics_sim):
    for seed in range(20):
        physics_sim.reset_state("open_drawer", seed, 0)
        if physics_sim.task.variation == 0:
            break
    target = physics_sim.task.variation
    wrong = (target + 1) % 3
    physics_sim.task.variation = wrong  # let the demonstrator open another drawer
    actions = list(physics_sim.task.demonstration())
    physics_sim.task.variation = target
    for action in actions:
        assert physics_sim.execute(action).ok
    assert physics_sim.task.travel()[wrong] > 0.15
    assert not physics_sim.is_success()


def test_grasped_reports_what_the_fingers_hold(physics_sim):
    physics_sim.reset_state("open_drawer", 4, 0)
    approach, grasp, _pull = list(physics_sim.task.demonstration())
    handle = physics_sim.task.handles[physics_sim.task.variation].entity.per_scene_id
    physics_sim.execute(approach)
    assert physics_sim.task.grasped() == set()
    physics_sim.execute(grasp)
    assert physics_sim.task.grasped() == {handle}
    physics_sim.execute(KeyAction(grasp.position, grasp.quat_wxyz, True))
    assert physics_sim.task.grasped() == set()


def test_pressing_a_wrong_button_first_is_not_a_success(physics_sim):
    physics_sim.reset_state("push_buttons", 0, 0)
    targets = list(physics_sim.task.targets)
    wrong = next(i for i in range(3) if i != targets[0])
    physics_sim.task.targets = [wrong]  # let the demonstrator press another button first ...
    wrong_press = list(physics_sim.task.demonstration())
    physics_sim.task.targets = targets
    right_presses = list(physics_sim.task.demonstration())  # ... then the named ones
    for action in wrong_press:
        assert not physics_sim.execute(action).success
    assert physics_sim.task.pressed[0] == wrong
    for action in right_presses:
        assert physics_sim.execute(action).ok
    assert set(targets) <= set(physics_sim.task.pressed)
    assert not physics_sim.is_success()


def test_close_microwave_counts_only_a_real_closing(physics_sim):
    physics_sim.reset_state("close_microwave", 5, 0)
    actions = list(physics_sim.task.demonstration())
    for action in actions[:3]:  # approach and the first 30-degree push
        physics_sim.execute(action)
    closed_by = np.rad2deg(physics_sim.task.start_angle - physics_sim.task.angle())
    assert 15 < closed_by < 40 and not physics_sim.is_success()
    for action in actions[3:]:
        last = physics_sim.execute(action)
    assert last.success


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize(
    "position, quat, why",
    [
        ((0.2, 0.0, 2.0), (0, 1, 0, 0), "outside the workspace"),
        ((0.2, 0.0, 0.70), (0, 1, 0, 0), "below the table"),
        ((0.69, 0.49, 0.61), (0, 1, 0, 0), "below the table"),
        ((0.69, -0.49, 1.59), (1, 0, 0, 0), "no joint configuration"),
        ((-0.29, 0.0, 0.8), (0, 1, 0, 0), "no joint configuration"),
        ((0.2, 0.0, 1.0), (0, 0, 0, 0), "zero length"),
        ((float("nan"), 0.0, 1.0), (0, 1, 0, 0), "not a finite"),
    ],
)
def test_unreachable_pose_is_reported_not_raised(physics_sim, position, quat, why):
    physics_sim.reset_state("push_buttons", 0, 0)
    before = physics_sim.robot.arm_qpos()
    outcome = physics_sim.execute(KeyAction(position, quat, True))
    assert not outcome.ok and outcome.error_kind == "unreachable" and not outcome.success
    assert why in outcome.error_message
    assert np.allclose(physics_sim.robot.arm_qpos(), before, atol=1e-3)  # the arm did not move


def test_execute_without_a_task_is_a_sim_error():
    from xicm.plugins.simulators.sapien.options import SapienOptions
    from xicm.plugins.simulators.sapien.simulator import SapienSimulator

    fresh = SapienSimulator(SapienOptions(render=False), tasks={})
    outcome = fresh.execute(KeyAction((0.2, 0.0, 1.0), (0, 1, 0, 0), True))
    assert not outcome.ok and outcome.error_kind == "sim_error"
    assert "reset" in outcome.error_message


# ------------------------------------------------------------------ replay
#: the replay check's tasks in the fast lane; the full suite replays every task (~2 min)
FAST_REPLAY_TASKS = ("open_drawer", "push_buttons", "close_jar", "put_money_in_safe")
REPLAY_TASKS = [
    pytest.param(t, marks=() if t in FAST_REPLAY_TASKS else (pytest.mark.slow, pytest.mark.every_task)) for t in TASKS
]


@pytest.mark.parametrize("task", REPLAY_TASKS)
def test_quantised_key_actions_of_a_demo_replay(physics_sim, task):
    """X-ICM's premise: the demo's key frames, as 7-integer text, solve the episode again."""
    for seed in (0, 1):
        physics_sim.reset_state(task, seed, 0)
        traj = physics_sim.demonstrate()
        actions = demo_key_actions(traj, physics_sim.workspace)
        # one LLM reply holds at most MAX_ACTIONS actions; longer demos need a re-query
        assert 2 <= len(actions) <= 2 * MAX_ACTIONS
        ok, err = replay(physics_sim, task, seed, 0, actions)
        assert ok, (seed, err)


def test_demonstrate_never_renders(sim, monkeypatch):
    sim.reset_state("push_buttons", 1, 0)

    def no_render(*args, **kwargs):
        raise AssertionError("rendered during a demonstration")

    monkeypatch.setattr(sim.world, "render", no_render)
    assert sim.demonstrate().success


# ------------------------------------------------------------------ cameras
def test_camera_frames(sim):
    obs = sim.reset("open_drawer", 2, 0)
    assert set(obs.cameras) == {"front", "left_shoulder", "right_shoulder", "overhead", "wrist"}
    assert obs.object_names == ["top drawer handle", "middle drawer handle", "bottom drawer handle"]
    assert obs.instruction.startswith("open the ") and obs.instruction.endswith(" drawer")
    assert set(obs.object_names) <= set(obs.segment_names.values())
    truth = sim.object_positions()
    seen_anywhere = set()
    for name, frame in obs.cameras.items():
        assert frame.rgb.shape == (128, 128, 3) and frame.rgb.dtype == np.uint8
        assert frame.depth.shape == (128, 128) and frame.depth.dtype == np.float32
        assert frame.segmentation.shape == (128, 128) and frame.segmentation.dtype == np.int32
        assert frame.intrinsic.shape == (3, 3) and frame.cam_to_world.shape == (4, 4)
        rot = frame.cam_to_world[:3, :3]
        np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-5)
        assert np.linalg.det(rot) == pytest.approx(1.0, abs=1e-5)
        assert np.all(frame.depth >= 0) and frame.rgb.std() > 5
        # back-project each visible object's pixels (OpenCV: x right, y down, z forward)
        for seg_id, object_name in obs.segment_names.items():
            v, u = np.nonzero((frame.segmentation == seg_id) & (frame.depth > 0))
            if len(u) < 3:
                continue
            seen_anywhere.add(object_name)
            k = frame.intrinsic
            z = frame.depth[v, u]
            cam = np.stack([(u - k[0, 2]) / k[0, 0] * z, (v - k[1, 2]) / k[1, 1] * z, z], axis=1)
            world = cam @ rot.T + frame.cam_to_world[:3, 3]
            assert np.linalg.norm(world.mean(axis=0) - truth[object_name]) < 0.25, (name, object_name)
    assert set(obs.object_names) <= seen_anywhere
    # the front camera looks along -x at the table; its optical axis points away from it
    front = obs.cameras["front"].cam_to_world
    assert front[0, 2] < -0.5 and front[2, 2] < 0


def test_observe_renders_only_the_named_cameras(sim):
    sim.reset_state("open_drawer", 2, 0)
    obs = sim.observe(cameras=["front"])
    assert set(obs.cameras) == {"front"}
    np.testing.assert_array_equal(obs.cameras["front"].rgb, sim.observe().cameras["front"].rgb)
    with pytest.raises(ValueError, match="no camera 'back'; cameras: front, "):
        sim.observe(cameras=["back"])


def test_segmentation_names_every_link_of_an_object(sim):
    obs = sim.reset("close_microwave", 0, 0)
    names = obs.segment_names
    assert sorted(set(names.values())) == ["microwave", "microwave door", "microwave door handle"]
    robot_ids = {link.entity.per_scene_id for link in sim.robot.links}
    assert not robot_ids & set(names)
    ids = np.unique(np.concatenate([f.segmentation.ravel() for f in obs.cameras.values()]))
    assert robot_ids & set(ids.tolist())  # the robot is visible but is not a task object


def test_intrinsics_follow_the_opencv_pixel_convention(sim):
    """Pixel (u, v) back-projects through its centre at (u, v): exact against SAPIEN's own points."""
    sim.reset("open_drawer", 0, 0)
    frame = sim.observe().cameras["front"]
    cam = sim.world.cameras.cameras["front"]
    position = cam.get_picture("Position")  # camera-space points of the same render (OpenGL axes)
    v, u = np.nonzero(frame.depth > 0)
    k = frame.intrinsic
    z = frame.depth[v, u]
    np.testing.assert_allclose((u - k[0, 2]) / k[0, 0] * z, position[v, u, 0], atol=1e-4)
    np.testing.assert_allclose((v - k[1, 2]) / k[1, 1] * z, -position[v, u, 1], atol=1e-4)


def test_wrist_camera_rides_on_the_hand(sim):
    obs = sim.reset("push_buttons", 0, 0)
    before = obs.cameras["wrist"].cam_to_world.copy()
    pose = obs.gripper
    target = KeyAction((pose.position[0] + 0.1, pose.position[1], pose.position[2] - 0.1), pose.quat_wxyz, True)
    assert sim.execute(target).ok
    after = sim.observe().cameras["wrist"].cam_to_world
    np.testing.assert_allclose(after[:3, 3] - before[:3, 3], [0.1, 0.0, -0.1], atol=0.01)


def test_variation_names_the_variation_reset_drew(sim):
    """close_jar's variation is the target jar's colour: sampled per (seed, task, episode), the
    instruction names that colour; with sample_variations off every episode is variation 0."""
    drawn = {}
    for episode in range(6):
        sim.reset_state("close_jar", 10_000, episode)
        drawn[episode] = (sim.variation(), sim.instruction())
    assert len({v for v, _ in drawn.values()}) > 1, drawn
    assert all(len({words for v2, words in drawn.values() if v2 == v}) == 1 for v, _ in drawn.values()), drawn
    sim.sample_variations = False
    try:
        for episode in drawn:
            sim.reset_state("close_jar", 10_000, episode)
            assert sim.variation() == 0
    finally:
        sim.sample_variations = True
