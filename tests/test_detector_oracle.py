"""Oracle detector on synthetic camera frames whose geometry is known exactly."""

import numpy as np
import pluggy
import pytest

from xicm.core.contracts import hookspecs
from xicm.core.assembly.plugins import Registry
from xicm.plugins.detectors import oracle
from xicm.core.contracts.types import CameraFrame, KeyAction, Observation
from xicm.plugins.detectors.oracle import OracleDetector, OracleOptions, backproject

H, W = 96, 128
K = np.array([[110.0, 0.0, 63.5], [0.0, 105.0, 47.5], [0.0, 0.0, 1.0]])


def look_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """cam_to_world in the OpenCV convention: x right, y down, z forward."""
    eye, target, up = (np.asarray(v, float) for v in (eye, target, up))
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    pose = np.eye(4)
    pose[:3, :3] = np.stack([x, y, z], axis=1)
    pose[:3, 3] = eye
    return pose


def frame(depth, seg, pose, k=K) -> CameraFrame:
    return CameraFrame(
        rgb=np.zeros((*depth.shape, 3), np.uint8),
        depth=depth.astype(np.float32),
        segmentation=seg.astype(np.int32),
        intrinsic=k,
        cam_to_world=pose,
    )


def obs_of(cameras, segment_names, names=("a", "b")) -> Observation:
    return Observation(
        instruction="x",
        cameras=cameras,
        segment_names=segment_names,
        object_names=list(names),
        gripper=KeyAction((0, 0, 0), (1, 0, 0, 0), True),
        joint_positions=np.zeros(9),
    )


def patch_frame(pose, patches, k=K):
    """Fronto-parallel square patches: (u0, v0, half_size, depth, seg id) -> exact centres.

    A patch perpendicular to the optical axis has constant depth and is sampled uniformly by
    the pixel grid, so the mean of its back-projected pixels is exactly the back-projection
    of its central pixel.
    """
    depth = np.zeros((H, W), np.float32)
    seg = np.zeros((H, W), np.int32)
    centres = []
    for u0, v0, r, z, sid in patches:
        depth[v0 - r : v0 + r + 1, u0 - r : u0 + r + 1] = z
        seg[v0 - r : v0 + r + 1, u0 - r : u0 + r + 1] = sid
        cam = np.linalg.inv(k) @ np.array([u0, v0, 1.0]) * z
        centres.append(pose[:3, :3] @ cam + pose[:3, 3])
    return frame(depth, seg, pose, k), centres


def test_registered_under_oracle():
    pm = pluggy.PluginManager("xicm")  # only this plugin: the others may not exist yet
    pm.add_hookspecs(hookspecs)
    pm.register(oracle)
    det = Registry(pm).create("detector", {"name": "oracle", "min_pixels": 3})
    assert isinstance(det, OracleDetector) and det.min_pixels == 3


def test_backproject_exact_with_rotated_camera_and_skewed_intrinsic():
    pose = look_at([1.2, -0.7, 1.9], [0.1, 0.2, 0.75])
    k = K.copy()
    k[0, 1] = 2.5  # skew
    rng = np.random.default_rng(0)
    world = rng.uniform([-0.2, -0.2, 0.75], [0.4, 0.5, 1.0], size=(50, 3))
    cam = (world - pose[:3, 3]) @ pose[:3, :3]  # world -> camera
    # integer pixels: move each point along its ray so its projection lands on a pixel centre
    uvw = cam @ k.T
    uv = np.round(uvw[:, :2] / uvw[:, 2:])
    depth = np.zeros((H, W), np.float32)
    mask = np.zeros((H, W), bool)
    expected = []
    for (u, v), z in zip(uv.astype(int), cam[:, 2]):
        if 0 <= u < W and 0 <= v < H and not mask[v, u]:
            depth[v, u] = z
            mask[v, u] = True
            p = np.linalg.inv(k) @ np.array([u, v, 1.0]) * np.float32(z)
            expected.append(((v, u), pose[:3, :3] @ p + pose[:3, 3]))
    f = frame(depth, mask.astype(np.int32), pose, k)
    pts = backproject(f, mask)
    expected.sort(key=lambda e: e[0])  # np.nonzero order: row-major
    np.testing.assert_allclose(pts, np.array([e[1] for e in expected]), atol=1e-9)


def test_mean_over_cameras_that_see_the_object():
    pose1 = look_at([1.0, 0.0, 1.5], [0.0, 0.0, 0.8])
    pose2 = look_at([-0.2, 1.1, 1.3], [0.1, -0.1, 0.7])  # a second, differently rotated camera
    f1, (a1, b1) = patch_frame(pose1, [(30, 40, 4, 1.1, 7), (90, 60, 3, 0.9, 9)])
    f2, (a2,) = patch_frame(pose2, [(70, 20, 5, 1.3, 8)])  # sees only "a" (id 8 = another link)
    obs = obs_of({"front": f1, "left": f2}, {7: "a", 8: "a", 9: "b", 11: "c"}, names=("a", "b", "c"))
    out = OracleDetector().detect(obs, ["b", "a", "c", "zzz"])
    assert list(out) == ["b", "a"]  # request order; unseen "c" and unknown "zzz" left out
    np.testing.assert_allclose(out["a"], (a1 + a2) / 2, atol=1e-6)
    np.testing.assert_allclose(out["b"], b1, atol=1e-6)
    # camera selection
    only_left = OracleDetector(OracleOptions(cameras=["left"])).detect(obs, ["a", "b"])
    assert list(only_left) == ["a"]
    np.testing.assert_allclose(only_left["a"], a2, atol=1e-6)
    with pytest.raises(KeyError, match="available: front, left"):
        OracleDetector(OracleOptions(cameras=["wrist"])).detect(obs, ["a"])


def test_min_pixels_and_invalid_depth():
    pose = look_at([1.0, 0.0, 1.5], [0.0, 0.0, 0.8])
    f, (a, _b) = patch_frame(pose, [(30, 40, 4, 1.1, 1), (90, 60, 1, 0.9, 2)])  # b: 3x3 = 9 pixels
    f.depth[40, 30] = 0.0  # pixels of "a" with no depth hit or an invalid depth are ignored
    f.depth[40, 29] = np.nan  # (symmetric around the centre pixel, so the mean stays exact)
    f.depth[40, 31] = np.inf
    obs = obs_of({"front": f}, {1: "a", 2: "b"})
    out = OracleDetector(OracleOptions(min_pixels=10)).detect(obs, ["a", "b"])
    assert list(out) == ["a"]
    np.testing.assert_allclose(out["a"], a, atol=1e-6)
    assert list(OracleDetector(OracleOptions(min_pixels=9)).detect(obs, ["a", "b"])) == ["a", "b"]


def raycast_table_square(pose, centre, half, seg_id=5, k=K):
    """Render a horizontal square (z = centre[2], side 2*half) seen by a pinhole camera."""
    v, u = np.mgrid[0:H, 0:W]
    rays = np.stack([u, v, np.ones_like(u)], -1).reshape(-1, 3).astype(float) @ np.linalg.inv(k).T
    dirs = rays @ pose[:3, :3].T  # world direction per unit camera depth
    t = (centre[2] - pose[2, 3]) / dirs[:, 2]  # camera depth where the ray meets the plane
    hit = pose[:3, 3] + dirs * t[:, None]
    inside = (t > 0) & (np.abs(hit[:, 0] - centre[0]) <= half) & (np.abs(hit[:, 1] - centre[1]) <= half)
    depth = np.where(inside, t, 0.0).reshape(H, W)
    seg = np.where(inside, seg_id, 0).reshape(H, W)
    return frame(depth, seg, pose, k)


def test_raycast_square_recovered_with_rotated_cameras():
    centre = np.array([0.25, -0.1, 0.76])
    cams = {
        "front": raycast_table_square(look_at([1.3, 0.0, 1.6], [0.2, 0.0, 0.75]), centre, 0.06),
        "over": raycast_table_square(look_at([0.2, -0.5, 1.8], [0.25, 0.0, 0.75]), centre, 0.06),
    }
    for f in cams.values():
        assert np.count_nonzero(f.segmentation) > 20
    # the front camera looks along -x with z up, so world +y is image right: the square at
    # y = -0.1 must appear left of the principal point and below it (OpenCV: y down)
    rows, cols = np.nonzero(cams["front"].segmentation)
    assert cols.mean() < K[0, 2] and rows.mean() > K[1, 2]
    out = OracleDetector().detect(obs_of(cams, {5: "sq"}, names=("sq",)), ["sq"])
    # pixels sample an oblique plane non-uniformly (perspective), so allow a few millimetres
    np.testing.assert_allclose(out["sq"], centre, atol=4e-3)
    assert abs(out["sq"][2] - centre[2]) < 1e-6  # every hit lies on the plane


def test_sapien_frames_follow_the_opencv_pixel_convention():
    """Back-projecting a rendered SAPIEN frame with its CameraFrame reproduces SAPIEN's own points."""
    from xicm.core.assembly.plugins import get_registry

    sim = get_registry().create_simulator({"name": "sapien", "cameras": ["front"]})
    try:
        obs = sim.reset("open_drawer", 0, 0)
        cam = sim.world.cameras.cameras["front"]  # the simulator's internals, for the reference
        position = cam.get_picture("Position")
        model = np.asarray(cam.get_model_matrix(), float)
    finally:
        sim.close()
    valid = position[..., 3] < 1
    reference = position[valid][:, :3] @ model[:3, :3].T + model[:3, 3]  # OpenGL camera -> world
    points = backproject(obs.cameras["front"], valid)
    assert np.abs(points - reference).max() < 1e-4
