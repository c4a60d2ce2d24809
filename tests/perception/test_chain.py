"""The ego kinematic chain (eqs. 9-10) and the space-to-ego covariance."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from perception import (
    Joint,
    KinematicChain,
    PerceptionError,
    default_head,
    percept_covariance,
)

NAMES = ["neck_pitch", "neck_roll", "neck_yaw", "head_tilt", "eye_tilt", "left_eye_pan", "right_eye_pan"]
angle = st.floats(-1.2, 1.2)


def homogeneous(R: np.ndarray, t=(0.0, 0.0, 0.0)) -> np.ndarray:
    M = np.eye(4)
    M[:3, :3] = R
    M[:3, 3] = t
    return M


def independent_product(chain: KinematicChain, q: list[float]) -> np.ndarray:
    M = chain.ego_from_base.copy()
    for j, a in zip(chain.joints, q, strict=False):
        M = M @ j.origin @ homogeneous(Rotation.from_euler(j.axis, a).as_matrix())
    return M @ chain.tip_from_camera


@given(q=st.lists(angle, min_size=6, max_size=6))
def test_default_head_is_product_of_joint_transforms(q: list[float]) -> None:
    chain = default_head()
    assert list(chain.names) == NAMES
    np.testing.assert_allclose(chain.ego_from_camera(q), independent_product(chain, q), atol=1e-12)
    as_dict = dict(zip(NAMES, q, strict=False))
    np.testing.assert_allclose(chain.ego_from_camera(as_dict), chain.ego_from_camera(q), atol=0)


@given(q=st.lists(angle, min_size=3, max_size=3), seed=st.integers(0, 1000))
def test_custom_chain_product(q: list[float], seed: int) -> None:
    rng = np.random.default_rng(seed)
    rots = Rotation.random(3, random_state=seed).as_matrix()
    origins = [homogeneous(rots[i], rng.normal(size=3)) for i in range(3)]
    joints = tuple(Joint(f"j{i}", "xyz"[i], origins[i]) for i in range(3))
    base = homogeneous(Rotation.from_euler("z", 0.4).as_matrix(), (0.1, 0.2, 0.3))
    tip = homogeneous(np.eye(3), (0.0, 0.0, 0.05))
    chain = KinematicChain(joints, base, tip)
    np.testing.assert_allclose(chain.ego_from_camera(q), independent_product(chain, q), atol=1e-12)


def test_zero_pose_camera_axes_and_right_camera() -> None:
    chain = default_head(baseline=0.093)
    L = chain.ego_from_camera(np.zeros(6))
    # OpenCV camera: z forward = ego x, x right = ego -y, y down = ego -z
    np.testing.assert_allclose(L[:3, :3], [[0, 0, 1], [-1, 0, 0], [0, -1, 0]], atol=1e-15)
    Rr = chain.ego_from_right_camera(np.zeros(7))
    np.testing.assert_allclose(Rr, L @ homogeneous(np.eye(3), (0.093, 0.0, 0.0)), atol=1e-15)
    # neck moves both cameras rigidly: right = left + baseline along the camera x axis
    q = {"neck_pitch": 0.2, "neck_roll": -0.1, "neck_yaw": 0.7, "head_tilt": 0.3, "eye_tilt": -0.2,
         "left_eye_pan": 0.0}  # fmt: skip
    L, Rr = chain.ego_from_camera(q), chain.ego_from_right_camera(q)
    np.testing.assert_allclose(Rr[:3, :3], L[:3, :3], atol=1e-12)
    np.testing.assert_allclose(Rr[:3, 3], L[:3, 3] + 0.093 * L[:3, 0], atol=1e-12)
    # the right eye pan turns only the right camera
    q2 = dict(q, right_eye_pan=0.3)
    np.testing.assert_allclose(chain.ego_from_camera(q2), L, atol=0)
    np.testing.assert_allclose(chain.ego_from_right_camera(q2)[:3, 3], Rr[:3, 3], atol=1e-12)
    assert not np.allclose(chain.ego_from_right_camera(q2)[:3, :3], Rr[:3, :3])


def test_point_jacobian_finite_differences() -> None:
    chain = default_head()
    q = np.array([0.1, -0.05, 0.4, 0.2, -0.1, 0.05, 0.05])
    x = np.array([0.3, -0.2, 2.5])
    J = chain.point_jacobian(q, x)
    h = 1e-6
    num = np.zeros((3, 7))
    for k in range(7):
        dq = np.zeros(7)
        dq[k] = h
        plus = (chain.ego_from_camera(q + dq) @ np.append(x, 1.0))[:3]
        minus = (chain.ego_from_camera(q - dq) @ np.append(x, 1.0))[:3]
        num[:, k] = (plus - minus) / (2 * h)
    np.testing.assert_allclose(J, num, atol=1e-8)
    assert np.all(J[:, 6] == 0)  # the right eye does not move the left camera


def test_point_jacobians_equal_finite_differences_per_point() -> None:
    chain = default_head()
    rng = np.random.default_rng(4)
    q = rng.uniform(-0.3, 0.3, 7)
    points = rng.uniform(-2.0, 2.0, (9, 3)) + [0.0, 0.0, 3.0]
    J = chain.point_jacobians(q, points)
    assert J.shape == (9, 3, 7)
    h = 1e-6
    for k in range(7):
        dq = np.zeros(7)
        dq[k] = h
        hom = np.column_stack([points, np.ones(len(points))])
        plus = (hom @ chain.ego_from_camera(q + dq).T)[:, :3]
        minus = (hom @ chain.ego_from_camera(q - dq).T)[:, :3]
        np.testing.assert_allclose(J[:, :, k], (plus - minus) / (2 * h), atol=1e-8)
    assert chain.point_jacobians(q, np.zeros((0, 3))).shape == (0, 3, 7)
    with pytest.raises(PerceptionError, match="points_camera"):
        chain.point_jacobians(q, np.ones((3, 2)))


def test_percept_covariance_monte_carlo() -> None:
    chain = default_head()
    q = np.array([0.15, 0.02, -0.5, 0.1, -0.05, 0.03])
    x = np.array([0.2, 0.1, 3.0])
    Cc = np.diag([1e-4, 2e-4, 9e-4])
    enc = np.array([2e-3, 1e-3, 3e-3, 2e-3, 1e-3, 2e-3, 1e-3])
    C = percept_covariance(chain, q, x, Cc, enc)
    rng = np.random.default_rng(7)
    m = 20000
    samples = np.empty((m, 3))
    pts = x + rng.multivariate_normal(np.zeros(3), Cc, m)
    qs = np.append(q, q[-1]) + rng.normal(size=(m, 7)) * enc
    for i in range(m):
        samples[i] = (chain.ego_from_camera(qs[i]) @ np.append(pts[i], 1.0))[:3]
    S = np.cov(samples.T)
    np.testing.assert_allclose(np.sqrt(np.diag(S)), np.sqrt(np.diag(C)), rtol=0.05)
    assert np.linalg.norm(S - C) / np.linalg.norm(C) < 0.06
    # without encoder noise: only the rotated camera covariance
    R = chain.ego_from_camera(q)[:3, :3]
    np.testing.assert_allclose(percept_covariance(chain, q, x, Cc, 0.0), R @ Cc @ R.T, atol=1e-18)


def test_bad_input() -> None:
    chain = default_head()
    with pytest.raises(PerceptionError, match=r"unknown joint names \['neck_twist'\]"):
        chain.ego_from_camera({n: 0.0 for n in NAMES[:6]} | {"neck_twist": 0.1})
    with pytest.raises(PerceptionError, match=r"angles lack joints \['neck_roll', 'neck_yaw',"):
        chain.ego_from_camera({"neck_pitch": 0.0})
    with pytest.raises(PerceptionError, match=r"angles must have shape \(6,\) or \(7,\), got.*\(5,\)"):
        chain.ego_from_camera(np.zeros(5))
    with pytest.raises(PerceptionError, match=r"angles\[2\] must be finite, got "):
        chain.ego_from_camera([0, 0, np.nan, 0, 0, 0])
    with pytest.raises(PerceptionError, match=r"joint 'a': axis must be 'x', 'y' or 'z',.*'w'"):
        Joint("a", "w", np.eye(4))
    with pytest.raises(PerceptionError, match=r"origin of joint 'a' must be a rigid transform"):
        Joint("a", "x", 2 * np.eye(4))
    with pytest.raises(PerceptionError, match=r"\(4, 4\)"):
        Joint("a", "x", np.eye(3))
    with pytest.raises(PerceptionError, match=r"joints \(and right_eye\): joint names must.*unique"):
        KinematicChain((Joint("a", "x", np.eye(4)), Joint("a", "y", np.eye(4))), np.eye(4), np.eye(4))
    with pytest.raises(PerceptionError, match=r"encoder_sigma must be >= 0, got \[\-1\.0, \-1\.0,"):
        percept_covariance(chain, np.zeros(6), [0, 0, 1], np.eye(3), -1.0)
    with pytest.raises(PerceptionError, match=r"point_cov_camera must have shape"):
        percept_covariance(chain, np.zeros(6), [0, 0, 1], np.eye(2), 0.01)
