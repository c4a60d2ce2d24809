"""Errors shared by the percepts of one view (head encoders): perception carries them as
loadings, fusion propagates them, and the pose covariance counts them."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import perception as pc
import radialopt as ro
from tests.worlds import skew
from worldgraph import scenes
from worldgraph.localization import localize
from worldgraph.pose import pose_information, refine_pose, transformation, weighted_rotation
from worldgraph.pose.validation import (
    CHI2_6_GATE,
    ros_pose_covariance,
    rotation_only_covariance,
    shared_range_covariance,
    shared_view_covariance,
)


def ros_error(true: np.ndarray, est: np.ndarray) -> np.ndarray:
    """(t_true - t_est, rotvec(R_true R_est^T)): the ROS-order pose error."""
    rot = Rotation.from_matrix(true[:3, :3] @ est[:3, :3].T).as_rotvec()
    return np.concatenate([true[:3, 3] - est[:3, 3], rot])


def test_sandwich_matches_monte_carlo_of_the_ml_pose() -> None:
    """Two views: each view's percepts share a small head rotation (0.3 deg) about the ego
    origin, dominating 5 mm of independent noise. Over 400 draws the ML pose's empirical
    covariance equals the inverse Fisher information plus the shared-view term, and the
    independent bound alone is overconfident."""
    rng = np.random.default_rng(7)
    k = 10
    ego = rng.uniform([1.0, -3.0, -0.5], [6.0, 3.0, 1.5], (k, 3))
    view = np.arange(k) % 2
    s_ind, s_rot = 0.005, np.radians(0.3)
    loads = [-skew(p) * s_rot for p in ego]  # d(rotated point)/d(rotation vector) * sigma
    covs = np.array([s_ind**2 * np.eye(3) + S @ S.T for S in loads])
    shared = [((int(v), S),) for v, S in zip(view, loads, strict=True)]
    true = np.eye(4)
    true[:3, :3] = Rotation.from_euler("zyx", [0.4, 0.05, -0.03]).as_matrix()
    true[:3, 3] = [2.0, 1.0, 0.3]
    world = ego @ true[:3, :3].T + true[:3, 3]
    errs = []
    for _ in range(400):
        e = rng.standard_normal((2, 3))
        noisy = ego + np.stack([S @ e[v] for S, v in zip(loads, view, strict=True)]) \
            + rng.normal(0.0, s_ind, (k, 3))
        est, _ = refine_pose(noisy, world, covs, true)
        errs.append(ros_error(true, est))
    errs = np.array(errs)
    emp = np.cov(errs.T)
    indep = ros_pose_covariance(pose_information(true, ego, covs))
    total = indep + shared_view_covariance(true, ego, covs, shared)
    # the shared views really matter here: the independent bound misses most of the variance
    assert np.trace(np.linalg.solve(indep, emp)) > 2 * 6
    # the corrected covariance explains the empirical one (mean NEES 6 within sampling error)
    nees = np.einsum("ni,ij,nj->n", errs, np.linalg.inv(total), errs)
    assert 5.2 < nees.mean() < 6.8
    np.testing.assert_allclose(np.sqrt(np.diag(emp)), np.sqrt(np.diag(total)), rtol=0.12)


def test_range_only_shared_term_matches_monte_carlo() -> None:
    """Range-only position (ML over the Gaussian spheres) then the rotation with the position
    fixed: each view's percepts share a 0.3 deg head rotation about a neck pivot off the ego
    origin (so it moves the ranges too). Over 400 draws the empirical 6D covariance equals
    rotation_only_covariance plus shared_range_covariance; without the shared term the bound
    is overconfident."""
    rng = np.random.default_rng(3)
    k = 10
    ego = rng.uniform([1.0, -3.0, -0.5], [6.0, 3.0, 1.5], (k, 3))
    view = np.arange(k) % 2
    s_ind, s_rot = 0.005, np.radians(0.3)
    pivot = np.array([-0.3, 0.0, 0.6])
    loads = [-skew(p - pivot) * s_rot for p in ego]
    covs = np.array([s_ind**2 * np.eye(3) + S @ S.T for S in loads])
    shared = [((int(v), S),) for v, S in zip(view, loads, strict=True)]
    true = np.eye(4)
    true[:3, :3] = Rotation.from_euler("zyx", [0.4, 0.05, -0.03]).as_matrix()
    true[:3, 3] = [2.0, 1.0, 0.3]
    centers = ego @ true[:3, :3].T + true[:3, 3]
    unit = ego / np.linalg.norm(ego, axis=1)[:, None]
    sig = np.sqrt(np.einsum("ka,kab,kb->k", unit, covs, unit))  # range sigma of the total covariance
    weights = rng.uniform(0.5, 2.0, k)
    errs = []
    for _ in range(400):
        e = rng.standard_normal((2, 3))
        noisy = ego + np.stack([S @ e[v] for S, v in zip(loads, view, strict=True)]) \
            + rng.normal(0.0, s_ind, (k, 3))
        spheres = ro.make_spheres(centers, np.linalg.norm(noisy, axis=1), sig)
        t = ro.estimate_position(spheres, method="ml").position
        errs.append(ros_error(true, transformation(weighted_rotation(noisy, centers - t, weights), t)))
    errs = np.array(errs)
    emp = np.cov(errs.T)
    indep = rotation_only_covariance(true, ego, covs, weights, ro.crlb(centers, sig, true[:3, 3]))
    total = indep + shared_range_covariance(true, ego, covs, centers, sig, weights, shared)
    nees = lambda C: np.einsum("ni,ij,nj->n", errs, np.linalg.inv(C), errs).mean()  # noqa: E731
    assert nees(indep) > 9.0
    assert 5.2 < nees(total) < 6.8
    np.testing.assert_allclose(np.sqrt(np.diag(emp)), np.sqrt(np.diag(total)), rtol=0.15)


def test_range_only_shared_term_is_zero_for_one_percept_per_view_and_checks_input() -> None:
    rng = np.random.default_rng(2)
    ego = rng.uniform(1, 4, (5, 3))
    centers = ego + 1.0
    T = np.eye(4)
    T[:3, 3] = 1.0
    covs = np.broadcast_to(1e-4 * np.eye(3), (5, 3, 3)).copy()
    S = np.eye(3)[:, :2] * 1e-3
    out = shared_range_covariance(T, ego, covs, centers, np.full(5, 0.01), np.ones(5),
                                  [((i, S),) for i in range(5)])
    np.testing.assert_allclose(out, 0.0, atol=1e-18)
    from worldgraph.errors import WorldGraphError

    with pytest.raises(WorldGraphError, match=r"sigmas\[2\] must be > 0"):
        shared_range_covariance(T, ego, covs, centers, [0.01, 0.01, 0.0, 0.01, 0.01], np.ones(5), [()] * 5)
    with pytest.raises(WorldGraphError, match="centers"):
        shared_range_covariance(T, ego, covs, centers[:4], np.full(5, 0.01), np.ones(5), [()] * 5)
    with pytest.raises(WorldGraphError, match="shared"):
        shared_range_covariance(T, ego, covs, centers, np.full(5, 0.01), np.ones(5), [()] * 4)


def test_no_shared_views_adds_nothing_and_bad_input_raises() -> None:
    rng = np.random.default_rng(1)
    ego = rng.uniform(-3, 3, (6, 3))
    covs = np.broadcast_to(1e-4 * np.eye(3), (6, 3, 3)).copy()
    T = np.eye(4)
    S = np.eye(3)[:, :1] * 1e-3
    # one percept per view: no cross terms
    out = shared_view_covariance(T, ego, covs, [((i, S),) for i in range(6)])
    np.testing.assert_allclose(out, 0.0, atol=1e-18)
    np.testing.assert_array_equal(shared_view_covariance(T, ego, covs, [()] * 6), np.zeros((6, 6)))
    from worldgraph.errors import WorldGraphError

    with pytest.raises(WorldGraphError, match="shared"):
        shared_view_covariance(T, ego, covs, [()] * 5)
    with pytest.raises(WorldGraphError, match=r"shared\[0\]\[0\] loading"):
        shared_view_covariance(T, ego, covs, [((0, np.ones((2, 2))),)] + [()] * 5)


def test_percept_rejects_loadings_beyond_its_covariance() -> None:
    S = np.array([[0.02], [0.0], [0.0]])
    ok = pc.Percept("door", [1.0, 2.0, 3.0], 0.02, covariance=1e-4 * np.eye(3) + S @ S.T, shared=[(3, S)])
    assert ok.shared[0][0] == 3
    with pytest.raises(pc.PerceptionError, match="exceed the covariance"):
        pc.Percept("door", [1.0, 2.0, 3.0], 0.01, shared=[(0, S)])
    with pytest.raises(pc.PerceptionError, match="repeats view"):
        pc.Percept("door", [1.0, 2.0, 3.0], 0.1, shared=[(0, S), (0, S)])
    with pytest.raises(pc.PerceptionError, match=r"shared\[0\] loading"):
        pc.Percept("door", [1.0, 2.0, 3.0], 0.1, shared=[(0, np.ones(3))])


def test_fusion_keeps_the_shared_part_of_each_view() -> None:
    """Two objects seen in the same two views: their fused percepts share both views, with
    loadings equal to the information-weighted average of the members' loadings."""
    S1, S2 = np.array([[0.01], [0.0], [0.0]]), np.array([[0.0], [0.01], [0.0]])
    cov = lambda S: 1e-4 * np.eye(3) + S @ S.T  # noqa: E731
    raw = [pc.Percept("knob", [2.0, 0.0, 0.0], 0.01, covariance=cov(S1), shared=[(0, S1)]),
           pc.Percept("knob", [2.0, 0.001, 0.0], 0.01, covariance=cov(S2), shared=[(1, S2)]),
           pc.Percept("knob", [0.0, 3.0, 0.0], 0.01, covariance=cov(S1), shared=[(0, S1)]),
           pc.Percept("knob", [0.0, 3.0, 0.001], 0.01, covariance=cov(S2), shared=[(1, S2)])]
    fused = pc.fuse_percepts(raw, bandwidth=0.2)
    assert len(fused) == 2
    for f in fused:
        assert [v for v, _ in f.shared] == [0, 1]
        A1, A2 = np.linalg.inv(cov(S1)), np.linalg.inv(cov(S2))
        C = np.linalg.inv(A1 + A2)
        np.testing.assert_allclose(dict(f.shared)[0], C @ A1 @ S1, atol=1e-15)
        np.testing.assert_allclose(dict(f.shared)[1], C @ A2 @ S2, atol=1e-15)


@pytest.mark.parametrize("method", ["ml", "spheres"])
def test_localize_pose_covariance_covers_encoder_dominated_scans(method: str) -> None:
    """End to end: scans whose head encoders (0.3 deg) dominate the stereo noise, fused and
    localised; the 6D pose error lies inside its 3-sigma gate in nearly every trial only when
    the shared views are counted."""
    world = scenes.kitchen(seed=0)
    inside, without = 0, 0
    trials = 12
    for seed in range(trials):
        rng = np.random.default_rng(300 + seed)
        T = np.eye(4)
        T[:3, :3] = Rotation.from_euler("z", rng.uniform(-np.pi, np.pi)).as_matrix()
        T[:3, 3] = [rng.uniform(3.0, 7.0), rng.uniform(2.5, 5.5), 0.0]
        raw = pc.simulate_scan(world.types, world.positions, T, rng, encoder_sigma=np.radians(0.3),
                               false_rate=0.0, depth_factor=3000.0)
        fused = pc.fuse_percepts(raw)
        res = localize(world, fused, method=method)
        assert res.status in ("ok", "weak", "ambiguous")
        e = ros_error(T, res.transformation)
        inside += e @ np.linalg.solve(res.pose_covariance, e) <= CHI2_6_GATE
        plain = [pc.Percept(p.type, p.position, p.sigma, covariance=p.covariance, views=p.views)
                 for p in fused]
        r0 = localize(world, plain, method=method)
        without += e @ np.linalg.solve(r0.pose_covariance, e) <= CHI2_6_GATE
    assert inside >= trials - 1
    assert without < inside
