"""Tests of worldgraph.pose: eq.-5 frames and weighted Kabsch."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from worldgraph.errors import PoseError, WorldGraphError
from worldgraph.pose import (
    invert_transformation,
    percept_frame,
    pose_from_frames,
    pose_information,
    refine_pose,
    rotation_angle,
    transformation,
    weighted_kabsch,
    weighted_kabsch_batch,
    weighted_rotation,
)

seeds = st.integers(0, 2**32 - 1)


def _random_rigid(rng: np.random.Generator) -> np.ndarray:
    rot = Rotation.random(random_state=rng).as_matrix()
    return transformation(rot, rng.uniform(-10, 10, 3))


@given(seeds)
def test_weighted_rotation_matches_scipy_align_vectors(seed: int) -> None:
    rng = np.random.default_rng(seed)
    k = int(rng.integers(3, 9))
    x = rng.normal(size=(k, 3))
    y = rng.normal(size=(k, 3))  # arbitrary, not a rigid image: a real least-squares problem
    w = rng.uniform(0.1, 5.0, k)
    rot = weighted_rotation(x, y, w)
    ref, _ = Rotation.align_vectors(y, x, weights=w)  # scipy: a rotation mapping x onto y
    assert np.allclose(rot, ref.as_matrix(), atol=1e-8)
    assert np.isclose(np.linalg.det(rot), 1.0)


@given(seeds)
def test_weighted_kabsch_recovers_random_rigid_transform(seed: int) -> None:
    rng = np.random.default_rng(seed)
    world_from_ego = _random_rigid(rng)
    k = int(rng.integers(3, 10))
    ego = rng.uniform(-5, 5, (k, 3))
    world = ego @ world_from_ego[:3, :3].T + world_from_ego[:3, 3]
    rot, t = weighted_kabsch(ego, world, rng.uniform(0.1, 10, k))
    assert np.allclose(rot, world_from_ego[:3, :3], atol=1e-9)
    assert np.allclose(t, world_from_ego[:3, 3], atol=1e-8)


@given(seeds)
def test_weighted_kabsch_is_weighted_least_squares(seed: int) -> None:
    """Against brute force: no random rigid motion beats the returned one on the weighted cost."""
    rng = np.random.default_rng(seed)
    k = 6
    x = rng.normal(size=(k, 3))
    y = x @ Rotation.random(random_state=rng).as_matrix().T + rng.normal(scale=0.3, size=(k, 3))
    w = rng.uniform(0.1, 3.0, k)
    rot, t = weighted_kabsch(x, y, w)

    def cost(r: np.ndarray, tt: np.ndarray) -> float:
        return float(np.sum(w * np.sum((x @ r.T + tt - y) ** 2, axis=1)))

    best = cost(rot, t)
    for _ in range(50):
        dr = Rotation.from_rotvec(rng.normal(scale=0.05, size=3)).as_matrix()
        assert cost(dr @ rot, t + rng.normal(scale=0.05, size=3)) >= best - 1e-12


def test_kabsch_reflection_gives_proper_rotation() -> None:
    """Mirror-image points: the unconstrained optimum is a reflection; we must return det +1."""
    rng = np.random.default_rng(3)
    x = rng.normal(size=(8, 3))
    mirror = np.diag([1.0, 1.0, -1.0])
    y = x @ mirror.T
    rot, t = weighted_kabsch(x, y, np.ones(8))
    assert np.isclose(np.linalg.det(rot), 1.0)
    assert np.allclose(rot @ rot.T, np.eye(3), atol=1e-12)
    ref, _ = Rotation.align_vectors(y - y.mean(0), x - x.mean(0))
    assert np.allclose(rot, ref.as_matrix(), atol=1e-8)
    # planar points in z = 0 mirrored: the proper rotation fits them exactly
    xp = x.copy()
    xp[:, 2] = 0.0
    rot2, t2 = weighted_kabsch(xp, xp @ mirror.T, np.ones(8))
    assert np.isclose(np.linalg.det(rot2), 1.0)
    assert np.allclose(xp @ rot2.T + t2, xp @ mirror.T, atol=1e-9)


@given(seeds)
def test_eq5_recovers_pose_from_noise_free_triple(seed: int) -> None:
    rng = np.random.default_rng(seed)
    world_from_ego = _random_rigid(rng)
    ego = rng.uniform(-5, 5, (3, 3))
    world = ego @ world_from_ego[:3, :3].T + world_from_ego[:3, 3]
    s_model = percept_frame(*world)
    s_percept = percept_frame(*ego)
    assert np.isclose(np.linalg.det(s_model[:3, :3]), 1.0)
    assert np.allclose(s_model[:3, :3].T @ s_model[:3, :3], np.eye(3), atol=1e-12)
    assert np.allclose(pose_from_frames(s_model, s_percept), world_from_ego, atol=1e-8)


def test_percept_frame_axes_by_hand() -> None:
    frame = percept_frame([1, 1, 1], [3, 1, 1], [1, 4, 1])
    # d1 = +x, d2 = x cross y = +z, d3 = d1 x d2 = -y
    expected = np.array([[1, 0, 0, 1], [0, 0, -1, 1], [0, 1, 0, 1], [0, 0, 0, 1]], dtype=float)
    assert np.allclose(frame, expected)


def test_invert_transformation() -> None:
    m = _random_rigid(np.random.default_rng(1))
    assert np.allclose(invert_transformation(m) @ m, np.eye(4), atol=1e-12)
    assert np.isclose(rotation_angle(np.eye(3), Rotation.from_rotvec([0, 0, 0.3]).as_matrix()), 0.3)


@pytest.mark.parametrize(
    ("a", "b", "c"),
    [([0, 0, 0], [1, 1, 1], [2, 2, 2]), ([0, 0, 0], [0, 0, 0], [1, 0, 0]), ([1, 2, 3], [1, 2, 3], [1, 2, 3])],
)
def test_percept_frame_rejects_collinear(a: list, b: list, c: list) -> None:
    with pytest.raises(PoseError, match="collinear"):
        percept_frame(a, b, c)


def test_bad_input() -> None:
    with pytest.raises(WorldGraphError, match=r"shape \(3,\)"):
        percept_frame([0, 0], [1, 0, 0], [0, 1, 0])
    with pytest.raises(WorldGraphError, match=r"a\[0\] must be finite, got nan"):
        percept_frame([np.nan, 0, 0], [1, 0, 0], [0, 1, 0])
    with pytest.raises(WorldGraphError, match=r"\(4, 3\)"):
        weighted_kabsch(np.zeros((4, 3)), np.zeros((3, 3)), np.ones(4))
    with pytest.raises(PoseError, match="weights"):
        weighted_kabsch(np.eye(3), np.eye(3), [1.0, -1.0, 1.0])
    with pytest.raises(WorldGraphError, match=r"weights must have shape"):
        weighted_kabsch(np.eye(3), np.eye(3), [1.0, 1.0])
    with pytest.raises(WorldGraphError, match=r"world_vectors\[0, 0\] must be finite, got inf"):
        weighted_rotation(np.eye(3), np.full((3, 3), np.inf), np.ones(3))


@given(seeds)
def test_batch_kabsch_matches_scipy(seed: int) -> None:
    rng = np.random.default_rng(seed)
    h, k = 5, int(rng.integers(3, 8))
    x = rng.normal(size=(h, k, 3))
    y = rng.normal(size=(h, k, 3))
    w = rng.uniform(0.1, 5.0, (h, k))
    rot, t = weighted_kabsch_batch(x, y, w)
    for i in range(h):
        wn = w[i] / w[i].sum()
        cx, cy = wn @ x[i], wn @ y[i]
        ref, _ = Rotation.align_vectors(y[i] - cy, x[i] - cx, weights=w[i])
        assert np.allclose(rot[i], ref.as_matrix(), atol=1e-8)
        assert np.allclose(t[i], cy - ref.as_matrix() @ cx, atol=1e-8)
    with pytest.raises(WorldGraphError, match=r"world_points must have shape \(5, \d, 3\), got shape \(5, 2"):
        weighted_kabsch_batch(x, y[:, :2], w)


def _anisotropic_covariances(rng: np.random.Generator, k: int) -> np.ndarray:
    """Stereo-like covariances: long along a random ray, short across it."""
    out = np.empty((k, 3, 3))
    for i in range(k):
        q = Rotation.random(random_state=rng.integers(2**31)).as_matrix()
        out[i] = q @ np.diag(rng.uniform(0.01, 0.05, 3) ** 2 * [1.0, 1.0, 25.0]) @ q.T
    return out


def _world_pose(rng: np.random.Generator) -> np.ndarray:
    return transformation(Rotation.random(random_state=rng.integers(2**31)).as_matrix(),
                          rng.uniform(-5, 5, 3))


@settings(max_examples=15)
@given(st.integers(0, 2**32 - 1))
def test_refine_pose_matches_a_generic_least_squares_solver(seed: int) -> None:
    """Anisotropic covariances: the Gauss-Newton optimum equals scipy's least_squares on the
    whitened ego-frame residuals (an independent, slow reference)."""
    from scipy.optimize import least_squares

    rng = np.random.default_rng(seed)
    k = int(rng.integers(4, 9))
    T = _world_pose(rng)
    X = rng.uniform(-4, 4, (k, 3)) + T[:3, 3]
    C = _anisotropic_covariances(rng, k)
    ego = (X - T[:3, 3]) @ T[:3, :3] + np.array([rng.multivariate_normal(np.zeros(3), c) for c in C])
    start = transformation(Rotation.from_rotvec(rng.normal(0, 0.05, 3)).as_matrix() @ T[:3, :3],
                           T[:3, 3] + rng.normal(0, 0.1, 3))
    pose, info = refine_pose(ego, X, C, start)
    L = np.linalg.cholesky(np.linalg.inv(C))  # whitening: |L^T r|^2 = r^T C^-1 r

    def residual(p):
        R = Rotation.from_rotvec(p[:3]).as_matrix()
        r = ego - (X - p[3:]) @ R  # ego-frame residual x - R^T (X - t)
        return np.einsum("kab,ka->kb", L, r).ravel()

    p0 = np.concatenate([Rotation.from_matrix(start[:3, :3]).as_rotvec(), start[:3, 3]])
    ref = least_squares(residual, p0, xtol=1e-14, ftol=1e-14, gtol=1e-14)
    ref_pose = transformation(Rotation.from_rotvec(ref.x[:3]).as_matrix(), ref.x[3:])
    np.testing.assert_allclose(pose, ref_pose, atol=1e-6)
    assert info.shape == (6, 6) and np.all(np.linalg.eigvalsh(info) > 0)


def test_refine_pose_isotropic_is_weighted_kabsch() -> None:
    rng = np.random.default_rng(5)
    T = _world_pose(rng)
    X = rng.uniform(-4, 4, (7, 3))
    s = rng.uniform(0.01, 0.1, 7)
    ego = (X - T[:3, 3]) @ T[:3, :3] + rng.normal(size=(7, 3)) * s[:, None]
    pose, _ = refine_pose(ego, X, s[:, None, None] ** 2 * np.eye(3), np.eye(4))
    R, t = weighted_kabsch(ego, X, 1.0 / s**2)
    np.testing.assert_allclose(pose, transformation(R, t), atol=1e-12)


def test_pose_information_is_the_inverse_covariance_of_the_ml_pose() -> None:
    """Monte-Carlo: the spread of the refined position matches the CRLB block (400 draws)."""
    rng = np.random.default_rng(8)
    T = _world_pose(rng)
    X = rng.uniform(-4, 4, (6, 3)) + T[:3, 3]
    C = _anisotropic_covariances(rng, 6)
    chol = np.linalg.cholesky(C)
    exact = (X - T[:3, 3]) @ T[:3, :3]
    positions = []
    for _ in range(400):
        ego = exact + np.einsum("kab,kb->ka", chol, rng.normal(size=(6, 3)))
        pose, _ = refine_pose(ego, X, C, T)
        positions.append(pose[:3, 3])
    sample = np.cov(np.array(positions).T)
    bound = np.linalg.inv(pose_information(T, exact, C))[3:, 3:]
    ratio = np.trace(sample) / np.trace(bound)
    assert 0.8 < ratio < 1.25, ratio
    with pytest.raises(PoseError, match="positive definite"):
        refine_pose(exact, X, -C, T)


@given(st.integers(0, 2**32 - 1), st.sampled_from([1.0, 1e-3, 1e-7, 1e-13, np.pi - 1e-9]))
def test_rotation_log_matches_scipy_rotvec(seed: int, scale: float) -> None:
    """The validation's rotation log (no scipy) against scipy's ``as_rotvec``: random axes at
    every angle, tiny angles (its series) and angles a hair below pi (its largest-diagonal
    branch); and ``_expm`` of it gives the matrix back."""
    from worldgraph.pose.frames import _expm, _logm

    rng = np.random.default_rng(seed)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    angle = rng.uniform(0.0, np.pi) if scale == 1.0 else scale * rng.uniform(0.5, 1.0) \
        if scale < 1.0 else scale
    R = Rotation.from_rotvec(angle * axis).as_matrix()
    got = _logm(R)
    want = Rotation.from_matrix(R).as_rotvec()
    assert np.allclose(got, want, rtol=1e-9, atol=1e-15 + 1e-9 * (np.pi - angle < 1e-6))
    assert np.allclose(_expm(got), R, atol=1e-14)


def test_rotation_log_at_pi_and_identity() -> None:
    from worldgraph.pose.frames import _logm

    assert np.array_equal(_logm(np.eye(3)), np.zeros(3))
    R = np.diag([1.0, -1.0, -1.0])  # a half turn about x: either sign of the axis is right
    got = _logm(R)
    assert np.isclose(abs(got[0]), np.pi) and np.allclose(got[1:], 0.0)
