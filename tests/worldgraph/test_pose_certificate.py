"""Tests of worldgraph.pose.certificate: the SDP certificate of the ML 6D pose vs brute force.

Random scenes: 4-10 landmarks uniform in a 10 m cube, the robot at a uniform position and a
uniformly random orientation, every ego point with its own random SPD covariance (random axes,
standard deviations ``noise * U(0.3, 1)``, ``noise`` log-uniform in [3 cm, 1 m]).  The
reference minimum is an independent brute force: 50 uniformly random rotation starts, each
refined with :func:`worldgraph.pose.refine_pose`, the best kept.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from radialopt import Certificate
from worldgraph.errors import (
    PoseError,
    TooFewPerceptsError,
    WorldGraphError,
)
from worldgraph.pose import refine_pose, transformation
from worldgraph.pose.certificate import (
    certify_pose,
    pose_cost,
    reduced_cost_matrix,
    solve_pose_sdp,
)

SCENES = 40
STARTS = 50


def scene(rng: np.random.Generator, k: int, noise: float):
    """``(ego, world, covariances, true world_from_ego)``."""
    world = rng.uniform(0.0, 10.0, (k, 3))
    R = Rotation.random(random_state=rng).as_matrix()
    t = rng.uniform(0.0, 10.0, 3)
    axes = Rotation.random(k, random_state=rng).as_matrix()
    sd = noise * rng.uniform(0.3, 1.0, (k, 3))
    C = np.einsum("kab,kb,kcb->kac", axes, sd**2, axes)
    noise_vec = np.einsum("kab,kb->ka", np.linalg.cholesky(C), rng.normal(size=(k, 3)))
    ego = (world - t) @ R + noise_vec
    return ego, world, C, transformation(R, t)


def brute_force(rng: np.random.Generator, ego, world, C, starts: int = STARTS):
    """Local minima ``[(cost, pose)]`` from random rotation starts, the cheapest first."""
    found = []
    for R0 in Rotation.random(starts, random_state=rng).as_matrix():
        T, _ = refine_pose(ego, world, C, transformation(R0, world.mean(0) - R0 @ ego.mean(0)),
                           max_iter=50)
        found.append((pose_cost(ego, world, C, T), T))
    found.sort(key=lambda a: a[0])
    return found


def best_translation(ego, world, C, R) -> np.ndarray:
    """The optimal translation for a fixed rotation (weighted least squares)."""
    W = np.linalg.inv(C)
    # r_i = x_i - R^T X_i + R^T t: linear in v = R^T t
    a = ego - world @ R
    v = -np.linalg.solve(W.sum(0), np.einsum("kab,kb->a", W, a))
    return R @ v


def _noise(rng: np.random.Generator) -> float:
    return float(np.exp(rng.uniform(np.log(0.03), np.log(1.0))))


@pytest.fixture(scope="module")
def certified_scenes():
    rng = np.random.default_rng(20240611)
    out = []
    for _ in range(SCENES):
        k = int(rng.integers(4, 11))
        ego, world, C, _ = scene(rng, k, _noise(rng))
        minima = brute_force(rng, ego, world, C)
        cert = certify_pose(ego, world, C, minima[0][1])
        out.append((ego, world, C, minima, cert, rng.integers(2**32)))
    return out


def test_reduced_matrix_gives_min_over_translation() -> None:
    rng = np.random.default_rng(1)
    for _ in range(20):
        ego, world, C, _ = scene(rng, int(rng.integers(3, 9)), _noise(rng))
        Q = reduced_cost_matrix(ego, world, C)
        assert np.all(np.linalg.eigvalsh(Q) >= -1e-9 * np.linalg.norm(Q))
        R = Rotation.random(random_state=rng).as_matrix()
        y = np.concatenate([R.T.reshape(-1, order="F"), [1.0]])
        f = pose_cost(ego, world, C, transformation(R, best_translation(ego, world, C, R)))
        assert np.isclose(y @ Q @ y, f, rtol=1e-8, atol=1e-8)
        other = pose_cost(ego, world, C, transformation(R, rng.uniform(0, 10, 3)))
        assert other >= y @ Q @ y - 1e-8 * other


def test_brute_force_optimum_is_certified(certified_scenes) -> None:
    certs = [c for *_, c, _ in certified_scenes]
    assert all(isinstance(c, Certificate) for c in certs)
    rate = np.mean([c.certified for c in certs])
    assert rate >= 0.95, [c.message for c in certs if not c.certified]
    for c in certs:
        if c.certified:
            assert c.method == "sdp" and c.gap >= 0.0
        else:
            assert c.method == "none"


def test_lower_bound_never_exceeds_brute_force_minimum(certified_scenes) -> None:
    for ego, world, C, minima, cert, _ in certified_scenes:
        fmin = minima[0][0]
        assert cert.lower_bound <= fmin * (1 + 1e-9) + 1e-9, cert.message
        # the bound holds for any pose given, optimal or not
        for _f, T in minima[-3:]:
            assert certify_pose(ego, world, C, T).lower_bound <= fmin * (1 + 1e-9) + 1e-9


def test_non_optimal_poses_are_never_certified(certified_scenes) -> None:
    offered = 0
    for ego, world, C, minima, _, seed in certified_scenes:
        rng = np.random.default_rng(seed)
        fmin, best = minima[0]
        axis = rng.normal(size=3)
        R = Rotation.from_rotvec(np.deg2rad(20.0) * axis / np.linalg.norm(axis)).as_matrix() @ best[:3, :3]
        rotated = transformation(R, best_translation(ego, world, C, R))
        assert pose_cost(ego, world, C, rotated) > fmin
        worse = [T for f, T in minima if f > fmin * 1.01 + 1e-3]
        for T in [rotated] + worse[:3]:
            offered += 1
            cert = certify_pose(ego, world, C, T)
            assert not cert.certified, cert.message
            assert cert.method == "none" and cert.gap > 0.0
    assert offered >= SCENES


@pytest.mark.parametrize("k", [3, 4])
def test_solve_pose_sdp_finds_the_global_optimum_with_few_matches(k: int) -> None:
    rng = np.random.default_rng(100 + k)
    n, found = 25, 0
    for _ in range(n):
        ego, world, C, _ = scene(rng, k, _noise(rng))
        fmin = brute_force(rng, ego, world, C)[0][0]
        T, lb = solve_pose_sdp(ego, world, C)
        f = pose_cost(ego, world, C, T)
        assert np.allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=1e-9) and np.linalg.det(T[:3, :3]) > 0
        assert lb <= fmin * (1 + 1e-9) + 1e-9 and lb <= f
        found += f <= fmin * (1 + 1e-6) + 1e-12
    assert found >= 0.95 * n


def test_solve_pose_sdp_is_exact_without_noise() -> None:
    rng = np.random.default_rng(7)
    ego, world, C, truth = scene(rng, 5, 0.1)
    ego = (world - truth[:3, 3]) @ truth[:3, :3]
    T, lb = solve_pose_sdp(ego, world, C)
    assert np.allclose(T, truth, atol=1e-6)
    assert pose_cost(ego, world, C, T) < 1e-9 and 0.0 <= lb < 1e-6


def _good():
    rng = np.random.default_rng(3)
    ego, world, C, truth = scene(rng, 5, 0.1)
    return ego, world, C, truth


@pytest.mark.parametrize(
    "change, error, name",
    [
        (dict(ego=np.zeros((5, 2))), WorldGraphError, r"ego_points must have shape \(n, 3\)"),
        (dict(world=np.zeros((4, 3))), WorldGraphError, r"world_points must have shape \(5, 3\)"),
        (dict(C=np.zeros((5, 3))), WorldGraphError, r"covariances must have shape \(n, 3, 3\)"),
        (dict(pose=np.eye(3)), WorldGraphError, r"world_from_ego must have shape \(4, 4\)"),
        (dict(ego=np.full((5, 3), np.nan)), WorldGraphError, r"ego_points\[0, 0\] must be finite"),
        (dict(world=np.full((5, 3), np.inf)), WorldGraphError, r"world_points\[0, 0\] must be finite"),
        (dict(C=np.full((5, 3, 3), np.nan)), WorldGraphError, r"covariances\[0, 0, 0\] must be finite"),
        (dict(pose=np.full((4, 4), np.nan)), WorldGraphError, r"world_from_ego\[0, 0\] must be finite"),
        (dict(C=-np.broadcast_to(np.eye(3), (5, 3, 3))), PoseError, "covariances"),
        (dict(pose=np.diag([1.0, 1.0, -1.0, 1.0])), WorldGraphError, "world_from_ego must be rigid.*reflect"),
        (dict(pose=np.diag([2.0, 1.0, 1.0, 1.0])), WorldGraphError, "world_from_ego must be rigid.*scaled"),
        (dict(abs_gap=-1.0), WorldGraphError, "abs_gap must be >= 0"),
        (dict(rel_gap=np.nan), WorldGraphError, "rel_gap must be finite"),
        (dict(solver="NO_SUCH_SOLVER"), PoseError, "solver"),
    ],
)
def test_bad_input_raises(change, error, name) -> None:
    ego, world, C, truth = _good()
    args = dict(ego=ego, world=world, C=C, pose=truth, abs_gap=1e-6, rel_gap=1e-6, solver="CLARABEL")
    args.update(change)
    with pytest.raises(error, match=name):
        certify_pose(args["ego"], args["world"], args["C"], args["pose"], solver=args["solver"],
                     abs_gap=args["abs_gap"], rel_gap=args["rel_gap"])
    assert issubclass(error, WorldGraphError)


def test_too_few_matches_raise() -> None:
    ego, world, C, truth = _good()
    with pytest.raises(TooFewPerceptsError, match="ego_points"):
        certify_pose(ego[:2], world[:2], C[:2], truth)
    with pytest.raises(TooFewPerceptsError, match="ego_points"):
        solve_pose_sdp(ego[:2], world[:2], C[:2])
    with pytest.raises(WorldGraphError, match=r"covariances must have shape"):
        solve_pose_sdp(ego, world, C[:4])
