"""StereoRig: projection, triangulation, rectification, files, bad input."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from perception import (
    BehindCameraError,
    PerceptionError,
    RobotFileError,
    StereoRig,
)

CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-15)


def distorted_rig() -> StereoRig:
    K1 = np.array([[520.0, 0.0, 322.0], [0.0, 518.0, 241.0], [0.0, 0.0, 1.0]])
    K2 = np.array([[515.0, 0.0, 318.0], [0.0, 516.0, 238.0], [0.0, 0.0, 1.0]])
    D1 = np.array([-0.21, 0.06, 0.001, -0.0015, 0.01])
    D2 = np.array([-0.18, 0.04, -0.0008, 0.001, 0.005])
    R, _ = cv2.Rodrigues(np.array([0.01, -0.02, 0.005]))
    T = np.array([[-0.093], [0.0015], [0.0008]])  # (3, 1) as cv2.stereoCalibrate returns it
    return StereoRig.from_opencv(K1, D1, K2, D2, R, T, (640, 480))


RIGS = {"default": StereoRig.default(), "distorted": distorted_rig()}


@st.composite
def visible_points(draw: st.DrawFn) -> np.ndarray:
    n = draw(st.integers(1, 6))
    z = draw(st.lists(st.floats(0.4, 8.0), min_size=n, max_size=n))
    fx = draw(st.lists(st.floats(-0.45, 0.45), min_size=n, max_size=n))
    fy = draw(st.lists(st.floats(-0.35, 0.35), min_size=n, max_size=n))
    z = np.array(z)
    return np.column_stack([np.array(fx) * z, np.array(fy) * z, z])


@pytest.mark.parametrize("name", sorted(RIGS))
def test_triangulate_agrees_with_direct_opencv_call(name: str) -> None:
    rig = RIGS[name]
    rng = np.random.default_rng(3)
    z = rng.uniform(0.5, 6.0, 50)
    X = np.column_stack([rng.uniform(-0.4, 0.4, 50) * z, rng.uniform(-0.3, 0.3, 50) * z, z])
    uv1, uv2 = rig.project(X)
    uv1 = uv1 + rng.normal(0, 0.7, uv1.shape)  # not exactly consistent pairs
    uv2 = uv2 + rng.normal(0, 0.7, uv2.shape)
    n1 = cv2.undistortPoints(uv1.reshape(-1, 1, 2), rig.K1, rig.D1, criteria=CRITERIA).reshape(-1, 2)
    n2 = cv2.undistortPoints(uv2.reshape(-1, 1, 2), rig.K2, rig.D2, criteria=CRITERIA).reshape(-1, 2)
    P1 = np.hstack([np.eye(3), np.zeros((3, 1))])
    P2 = np.hstack([rig.R, rig.T.reshape(3, 1)])
    H = cv2.triangulatePoints(P1, P2, n1.T.copy(), n2.T.copy())
    expected = (H[:3] / H[3]).T
    np.testing.assert_allclose(rig.triangulate(uv1, uv2), expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize("name", sorted(RIGS))
@given(X=visible_points())
def test_project_then_triangulate_round_trip(name: str, X: np.ndarray) -> None:
    rig = RIGS[name]
    uv1, uv2 = rig.project(X)
    np.testing.assert_allclose(rig.triangulate(uv1, uv2), X, rtol=0, atol=1e-6)


def test_project_matches_pinhole_arithmetic() -> None:
    rig = StereoRig.default()
    X = np.array([[0.3, -0.2, 2.5], [-1.0, 0.4, 4.0]])
    f, cx, cy = rig.K1[0, 0], rig.K1[0, 2], rig.K1[1, 2]
    uv1, uv2 = rig.project(X)
    np.testing.assert_allclose(uv1, np.column_stack([f * X[:, 0] / X[:, 2] + cx, f * X[:, 1] / X[:, 2] + cy]))
    # right camera is 0.093 m along +x: its image of X is shifted by f b / z to the left
    np.testing.assert_allclose(uv2[:, 0], uv1[:, 0] - f * 0.093 / X[:, 2])
    np.testing.assert_allclose(uv2[:, 1], uv1[:, 1])


def test_default_rig_parameters() -> None:
    rig = StereoRig.default(image_size=(800, 600), baseline=0.1, hfov_deg=90.0)
    assert rig.focal_px == pytest.approx(400.0)  # (w / 2) / tan(45 deg)
    assert rig.baseline == pytest.approx(0.1)
    np.testing.assert_allclose(rig.right_center, [0.1, 0.0, 0.0])
    assert np.degrees(rig.hfov) == pytest.approx(90.0)
    assert rig.image_size == (800, 600)


def test_rectify_aligns_epipolar_lines() -> None:
    rig = distorted_rig()
    rect = rig.rectify()
    assert rect.P1.shape == (3, 4) and rect.Q.shape == (4, 4)
    rng = np.random.default_rng(5)
    z = rng.uniform(1.0, 5.0, 20)
    X = np.column_stack([rng.uniform(-0.3, 0.3, 20) * z, rng.uniform(-0.2, 0.2, 20) * z, z])
    uv1, uv2 = rig.project(X)
    r1 = cv2.undistortPoints(uv1.reshape(-1, 1, 2), rig.K1, rig.D1, R=rect.R1, P=rect.P1, criteria=CRITERIA)
    r2 = cv2.undistortPoints(uv2.reshape(-1, 1, 2), rig.K2, rig.D2, R=rect.R2, P=rect.P2, criteria=CRITERIA)
    np.testing.assert_allclose(r1[:, 0, 1], r2[:, 0, 1], atol=1e-6)
    # Q maps (u, v, disparity, 1) to the point in the rectified left frame: depth = rectified z
    d = r1[:, 0, 0] - r2[:, 0, 0]
    h = np.column_stack([r1[:, 0, 0], r1[:, 0, 1], d, np.ones(20)]) @ rect.Q.T
    depth = h[:, 2] / h[:, 3]
    np.testing.assert_allclose(depth, (X @ rect.R1.T)[:, 2], rtol=1e-6)


def test_in_view() -> None:
    rig = StereoRig.default()
    X = np.array([[0.0, 0.0, 2.0], [5.0, 0.0, 2.0], [0.0, 0.0, -1.0], [0.0, 3.0, 2.0]])
    np.testing.assert_array_equal(rig.in_view(X), [True, False, False, False])


def test_file_round_trip(tmp_path) -> None:
    rig = distorted_rig()
    path = tmp_path / "rig.yaml"
    rig.to_file(path)
    back = StereoRig.from_file(path)
    for key in ("K1", "D1", "K2", "D2", "R", "T"):
        np.testing.assert_array_equal(getattr(back, key), getattr(rig, key))
    assert back.image_size == rig.image_size
    plain = StereoRig.from_opencv(rig.K1, None, rig.K2, None, rig.R, rig.T, (320, 240))  # no distortion
    plain.to_file(tmp_path / "plain.yaml")
    back = StereoRig.from_file(tmp_path / "plain.yaml")
    np.testing.assert_array_equal(back.D1, np.zeros(5))
    np.testing.assert_array_equal(back.K2, plain.K2)
    assert back.image_size == (320, 240)


def test_file_errors(tmp_path) -> None:
    with pytest.raises(RobotFileError, match="does not exist"):
        StereoRig.from_file(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("%YAML:1.0\nK1: [1, 2\n  : : garbage {{{\n")
    with pytest.raises(RobotFileError, match=r"calibration.*bad.yaml"):
        StereoRig.from_file(bad)
    partial = tmp_path / "partial.yaml"
    fs = cv2.FileStorage(str(partial), cv2.FILE_STORAGE_WRITE)
    fs.write("K1", np.eye(3))
    fs.release()
    with pytest.raises(RobotFileError, match=r"calibration file.*'D1'"):
        StereoRig.from_file(partial)
    wrong = tmp_path / "wrong.yaml"
    rig = StereoRig.default()
    fs = cv2.FileStorage(str(wrong), cv2.FILE_STORAGE_WRITE)
    for key in ("K1", "D1", "K2", "D2", "R"):
        fs.write(key, np.atleast_2d(getattr(rig, key)))
    fs.write("T", np.zeros((2, 1)))
    fs.write("image_size", np.array([[640, 480]], dtype=np.int32))
    fs.release()
    with pytest.raises(PerceptionError, match="T"):
        StereoRig.from_file(wrong)


def test_bad_input() -> None:
    rig = StereoRig.default()
    with pytest.raises(PerceptionError, match=r"uv_left\[0, 0\] must be finite,.*nan"):
        rig.triangulate([[np.nan, 10.0]], [[5.0, 10.0]])
    with pytest.raises(PerceptionError, match=r"uv_right\[0, 0\] must be finite,.*inf"):
        rig.triangulate([[1.0, 10.0]], [[np.inf, 10.0]])
    with pytest.raises(BehindCameraError, match="depth"):
        rig.project([[0.0, 0.0, -1.0]])
    with pytest.raises(BehindCameraError):
        # right image point to the right of the left one: the rays meet behind the cameras
        rig.triangulate([[300.0, 240.0]], [[310.0, 240.0]])
    with pytest.raises(PerceptionError, match=r"\(n, 3\)"):
        rig.project([1.0, 2.0, 3.0])
    with pytest.raises(PerceptionError, match="same shape"):
        rig.triangulate(np.zeros((2, 2)), np.zeros((3, 2)))
    with pytest.raises(PerceptionError, match=r"\(n, 2\)"):
        rig.triangulate(np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(PerceptionError, match=r"R must be a rotation matrix, but it is scaled or"):
        StereoRig.from_opencv(rig.K1, None, rig.K2, None, 2 * np.eye(3), [0.1, 0, 0], (640, 480))
    with pytest.raises(PerceptionError, match=r"D1 must hold"):
        StereoRig.from_opencv(rig.K1, np.zeros(3), rig.K2, None, np.eye(3), [0.1, 0, 0], (640, 480))
    with pytest.raises(PerceptionError, match=r"K1 focal lengths must be > 0, got"):
        StereoRig.from_opencv(-rig.K1, None, rig.K2, None, np.eye(3), [0.1, 0, 0], (640, 480))


@pytest.mark.parametrize("focal", [1e-300, 1e-30, 1e-12])
def test_an_unusable_rig_is_refused_when_made(focal: float) -> None:
    """A rig whose focal length leaves no disparity for a point 2 m ahead (every point projects
    to the principal point) cannot triangulate: refused at construction, naming the focal length;
    the same rig with a real focal length round-trips that point."""
    K = np.array([[focal, 0.0, 320.0], [0.0, focal, 240.0], [0.0, 0.0, 1.0]])
    with pytest.raises(PerceptionError, match=r"cannot triangulate.*K1\[0, 0\]"):
        StereoRig.from_opencv(K, np.zeros(5), K, np.zeros(5), np.eye(3), [-0.093, 0.0, 0.0], (640, 480))
    K[0, 0] = K[1, 1] = 550.0
    rig = StereoRig.from_opencv(K, np.zeros(5), K, np.zeros(5), np.eye(3), [-0.093, 0.0, 0.0], (640, 480))
    point = np.array([[0.0, 0.0, 2.0]])
    np.testing.assert_allclose(rig.triangulate(*rig.project(point)), point, atol=1e-9)


def test_a_rig_whose_right_camera_looks_away_is_not_tested_by_that_point() -> None:
    # the right camera turned 180 degrees about y: the point ahead of the left camera is behind it
    R = np.diag([-1.0, 1.0, -1.0])
    K = np.array([[550.0, 0.0, 320.0], [0.0, 550.0, 240.0], [0.0, 0.0, 1.0]])
    rig = StereoRig.from_opencv(K, None, K, None, R, [0.0, 0.0, -0.5], (640, 480))
    assert rig.T.tolist() == [0.0, 0.0, -0.5]
