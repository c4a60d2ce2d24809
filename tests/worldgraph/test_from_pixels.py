"""From pixels to the pose: MuJoCo scans of the Franka kitchen, robot poses in free space, the
fusion bandwidth from the percepts, and the coherent fusion of an object's shared offset.

The kitchen (gymnasium-robotics' MJCF files) is a scene nobody on the team wrote; the test set-up
installs it (``pip install --no-deps gymnasium-robotics``).
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

import importlib.util  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

import perception as pc  # noqa: E402
import worldgraph as wg  # noqa: E402
from perception.frontend.detection_percepts import _percept  # noqa: E402

mujoco = pytest.importorskip("mujoco")
if importlib.util.find_spec("gymnasium_robotics") is None:  # the data package of the test set-up
    pytest.skip("gymnasium-robotics (the Franka kitchen's files) not installed", allow_module_level=True)

from perception.mujoco import MujocoScene  # noqa: E402
from worldgraph.importers.franka import FRANKA_BODY_TYPES, franka_kitchen_path  # noqa: E402

KITCHEN = franka_kitchen_path() / "kitchen_env_model.xml"


@pytest.fixture(scope="module")
def kitchen():
    return MujocoScene(KITCHEN, type_of=FRANKA_BODY_TYPES), wg.WorldModel.from_file(KITCHEN,
                                                                                   type_of=FRANKA_BODY_TYPES)


def test_a_small_seeded_scan_localises_the_franka_kitchen(kitchen):
    scene, world = kitchen
    truth = scene.robot_poses(1, np.random.default_rng(3))[0]
    scan = scene.scan(truth, "rgbd", 12, rng=np.random.default_rng(3), image_size=(320, 240),
                      pitch_deg=(-20.0, 0.0))
    fused = pc.fuse_percepts(list(scan.percepts), bandwidth=pc.percept_bandwidths(scan.percepts))
    result = wg.localize(world, fused)
    assert result.status == "ok", result.summary()
    error = truth[:3, 3] - result.transformation[:3, 3]
    rotation = Rotation.from_matrix(truth[:3, :3] @ result.transformation[:3, :3].T).magnitude()
    assert np.linalg.norm(error) < 0.10 and np.degrees(rotation) < 2.0
    turn = Rotation.from_matrix(truth[:3, :3] @ result.transformation[:3, :3].T).as_rotvec()
    e6 = np.concatenate([error, turn])
    assert e6 @ np.linalg.solve(result.pose_covariance, e6) < 20.06  # within its own 3-sigma (chi2, 6 dof)


def test_robot_poses_stand_level_in_free_space_facing_the_kitchen(kitchen):
    scene, _ = kitchen
    poses = scene.robot_poses(30, np.random.default_rng(0), clearance=0.4, head_height=(1.2, 1.7))
    model, data = scene.model, mujoco.MjData(scene.model)
    mujoco.mj_forward(model, data)
    boxes = []  # every non-plane geom's world box, written out here
    for g in range(model.ngeom):
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE:
            continue
        R = data.geom_xmat[g].reshape(3, 3)
        c = R @ model.geom_aabb[g, :3] + data.geom_xpos[g]
        h = np.abs(R) @ model.geom_aabb[g, 3:]
        boxes.append((c - h, c + h))
    for pose in poses:
        np.testing.assert_allclose(pose[:3, 2], [0.0, 0.0, 1.0], atol=1e-12)  # level: ego z is up
        x, y, z = pose[:3, 3]
        assert 1.2 <= z <= 1.7  # the floor plane is at z = 0
        for lo, hi in boxes:  # the body's column keeps 0.4 m from every geom below the head
            overlaps = (lo[0] < x + 0.4 and hi[0] > x - 0.4 and lo[1] < y + 0.4 and hi[1] > y - 0.4
                        and lo[2] < z + 0.4 and hi[2] > 0.05)
            assert not overlaps
        ahead = pose[:3, 0]
        to_objects = scene.positions - pose[:3, 3]
        cos = (to_objects[:, :2] @ ahead[:2]) / np.linalg.norm(to_objects[:, :2], axis=1)
        assert cos.max() > np.cos(np.radians(31.0))  # facing one of the objects, within 30 deg
    with pytest.raises(pc.PerceptionError, match="head_height"):
        scene.robot_poses(1, np.random.default_rng(0), head_height=(2.0, 1.0))


def test_default_centre_offsets_are_measured_once_and_cover_every_type(kitchen):
    scene, _ = kitchen
    offsets = scene.default_centre_offsets()
    assert set(offsets) == set(scene.types)
    assert offsets["door"].depth < 0  # the handles protrude: the door's centre is in front of its leaf
    assert 0.0 < offsets["knob"].depth < 0.03 and 0.0 < offsets["switch"].depth < 0.04
    assert scene.default_centre_offsets() == offsets  # cached: the same measurement


def test_percept_bandwidths_from_the_percepts_own_spread():
    knobs = [pc.Percept("knob", [2.0, 0.12 * k, 1.0], covariance=np.diag([0.01, 0.004, 0.004]) ** 2)
             for k in range(4)]
    door = pc.Percept("door", [3.0, 0.0, 1.0], 0.03)
    bw = pc.percept_bandwidths(knobs + [door], n_sigma=3.0, minimum=0.02)
    assert bw == pytest.approx({"knob": 0.03, "door": 0.09})  # 3 x the largest sd: 1 cm and 3 cm
    assert pc.percept_bandwidths(knobs, minimum=0.05) == pytest.approx({"knob": 0.05})
    raw = [pc.Percept(p.type, p.position + d, covariance=p.covariance) for p in knobs
           for d in ([0.005, 0, 0], [-0.005, 0, 0])]
    assert len(pc.fuse_percepts(raw, bandwidth=pc.percept_bandwidths(raw))) == 4  # 12 cm apart: four
    assert len(pc.fuse_percepts(raw, bandwidth=0.15)) < 4  # a fixed 15 cm merges neighbours
    with pytest.raises(pc.PerceptionError, match="n_sigma"):
        pc.percept_bandwidths(knobs, n_sigma=0.0)


def test_views_from_different_directions_keep_the_objects_offset_in_the_fused_covariance():
    # one offset covariance, seen from two camera orientations: each view's loading is built in
    # its own camera axes; fused, the shared part must stay whole (not cancel between the views)
    offset = np.diag([0.02, 0.01, 0.005]) ** 2
    percepts = []
    for yaw in (0.0, 50.0):
        R = Rotation.from_euler("z", yaw, degrees=True).as_matrix()  # camera axes in the ego frame
        local = R.T @ offset @ R
        w, V = np.linalg.eigh(local)
        loading = R @ (V * np.sqrt(w))  # a non-symmetric root, in the camera's own basis
        own = 1e-6 * np.eye(3)
        ego_from_camera = np.eye(4)
        ego_from_camera[:3, :3] = R
        percepts.append(_percept(pc.Detection("door", centroid_uv=[1.0, 1.0], area=9.0),
                                 R.T @ np.array([2.0, 0.0, 1.0]), own, R.T @ loading, ego_from_camera, None))
    fused = pc.fuse_percepts(percepts, bandwidth=0.2)[0]
    assert np.all(np.linalg.eigvalsh(fused.covariance - offset) > -1e-9)  # at least the offset
