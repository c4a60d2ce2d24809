"""project_radii_batch: the dual active set vectorised across instances against the slow,
obvious reference (one single-instance solve per instance) and against cvxpy."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import radialopt as ro
import radialopt.projection as proj
import radialopt.projection.batch as batch_module
from radialopt._projection_types import _Problem
from radialopt.polytope import pair_pattern
from radialopt.projection.batch import _batch_dual_active_set, _project_radii_batch_reference
from tests.problems import sphere_sets


def random_batch(rng: np.random.Generator, k: int, n: int, noise: float = 3.0, sigma_spread: float = 1.0):
    """k instances of n spheres around a random robot; ranges off by ``noise`` sigmas (most of
    them infeasible); sigmas spread over ``sigma_spread`` decades."""
    C = rng.uniform(-2, 2, size=(k, n, 3))
    robot = rng.uniform(-2, 2, size=(k, 1, 3))
    rho = np.linalg.norm(C - robot, axis=2)
    S = 0.01 * 10.0 ** rng.uniform(0, sigma_spread, size=(k, n))
    R = np.abs(rho + noise * S * rng.standard_normal((k, n)))
    return C, R, S


def grid_batch(rng: np.random.Generator, k: int, n: int):
    """Degenerate instances: integer centres and radii, sigmas 1 or 2 (ties, dependent rows)."""
    out_c = np.empty((k, n, 3))
    for b in range(k):
        pts = rng.choice(125, size=n, replace=False)
        out_c[b] = np.stack([pts // 25, (pts // 5) % 5, pts % 5], axis=1) - 2.0
    return out_c, rng.integers(0, 5, size=(k, n)).astype(float), rng.choice([1.0, 2.0], size=(k, n))


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6, 8])
def test_batch_equals_the_single_solve_loop(n):
    rng = np.random.default_rng(100 + n)
    C, R, S = random_batch(rng, 400, n, sigma_spread=2.0)
    out = ro.project_radii_batch(C, R, S)
    ref = _project_radii_batch_reference(C, R, S)
    np.testing.assert_allclose(out.radii, ref, rtol=0, atol=1e-12)
    z = (ref - R) / S
    np.testing.assert_allclose(out.normalized_displacement, np.linalg.norm(z, axis=1), rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(out.density, np.exp(-0.5 * np.sum(z * z, axis=1)), rtol=1e-10, atol=1e-300)
    assert np.sum(out.density < 1) > 50  # the instances do need projecting


@pytest.mark.parametrize("n", [3, 4, 6])
def test_batch_equals_single_on_degenerate_grid_instances(n):
    rng = np.random.default_rng(7 + n)
    C, R, S = grid_batch(rng, 300, n)
    out = ro.project_radii_batch(C, R, S)
    for k in range(len(C)):
        single = ro.project_radii(centers=C[k], radii=R[k], sigmas=S[k])
        np.testing.assert_allclose(out.radii[k], single.radii, rtol=0, atol=1e-12, err_msg=f"instance {k}")


def test_vectorised_core_certifies_and_matches_the_reference():
    """The vectorised loop itself (not its fall-back) settles on almost every instance, and where
    it says ok its answer is the single solve's."""
    rng = np.random.default_rng(5)
    C, R, S = random_batch(rng, 2000, 4)
    iu, ju, A, b_sign = pair_pattern(4)
    d = np.linalg.norm(C[:, iu] - C[:, ju], axis=2)
    h = b_sign * np.repeat(d, 3, axis=1) - R @ A.T
    z, ok = _batch_dual_active_set(A, S, h)
    assert ok.mean() > 0.99
    ref = _project_radii_batch_reference(C, R, S)
    np.testing.assert_allclose((R + S * z)[ok], ref[ok], rtol=0, atol=1e-12)


def test_instances_the_core_leaves_go_through_the_single_route(monkeypatch):
    rng = np.random.default_rng(6)
    C, R, S = random_batch(rng, 50, 4)

    def nothing_certified(A, sg, h):
        return np.full(sg.shape, np.nan), np.zeros(len(sg), dtype=bool)

    monkeypatch.setattr(batch_module, "_batch_dual_active_set", nothing_certified)
    out = ro.project_radii_batch(C, R, S)
    np.testing.assert_allclose(out.radii, _project_radii_batch_reference(C, R, S), rtol=0, atol=0)


def test_batch_beyond_the_small_core_and_empty_batch():
    rng = np.random.default_rng(9)
    C, R, S = random_batch(rng, 5, proj.SMALL_CORE_SPHERES + 1)
    out = ro.project_radii_batch(C, R, S)
    np.testing.assert_allclose(out.radii, _project_radii_batch_reference(C, R, S), rtol=0, atol=1e-12)
    empty = ro.project_radii_batch(np.zeros((0, 4, 3)), np.zeros((0, 4)), np.ones((0, 4)))
    assert empty.radii.shape == (0, 4) and empty.density.shape == (0,)


def test_batch_agrees_with_cvxpy_on_a_sample():
    rng = np.random.default_rng(11)
    C, R, S = random_batch(rng, 12, 5, noise=5.0)
    out = ro.project_radii_batch(C, R, S)
    for k in range(len(C)):
        cvx = ro.project_radii(centers=C[k], radii=R[k], sigmas=S[k], method="cvxpy")
        np.testing.assert_allclose(out.radii[k], cvx.radii, rtol=0, atol=1e-9)
        # the raw interior-point answer, before the exact polish, agrees to its own accuracy
        p = _Problem.from_arrays(C[k], R[k], S[k], ro.TOLERANCES)
        prob, z = proj.fresh_cvxpy_problem(p.G, p.h)
        prob.solve(solver="CLARABEL", **proj.solver_options("CLARABEL"))
        np.testing.assert_allclose(out.radii[k], R[k] + S[k] * z.value, rtol=0, atol=1e-5)


@given(st.lists(sphere_sets(min_n=4, max_n=4), min_size=1, max_size=12))
def test_batch_equals_single_on_hypothesis_instances(sets):
    C = np.array([[s.center for s in b] for b in sets])
    R = np.array([[s.radius for s in b] for b in sets])
    S = np.array([[s.sigma for s in b] for b in sets])
    out = ro.project_radii_batch(C, R, S)
    for k, b in enumerate(sets):
        single = ro.project_radii(b)
        scale = max(float(np.abs(C[k]).max()), float(R[k].max()), 1.0)
        np.testing.assert_allclose(out.radii[k], single.radii, rtol=0, atol=1e-12 * scale)


def test_batch_sigma_range_names_the_instance():
    rng = np.random.default_rng(12)
    C, R, S = random_batch(rng, 6, 4)
    S[3, 1] = 1e-20
    with pytest.raises(ro.RadialError, match=r"sigmas\[3\]\[1\] = 1e-20"):
        ro.project_radii_batch(C, R, S)
    R[2, 0] = -1.0
    with pytest.raises(ro.RadialError, match=r"radii\[2, 0\] = -1.0"):
        ro.project_radii_batch(C, R, np.abs(S) + 0.01)
