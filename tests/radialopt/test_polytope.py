"""The restriction polytope (eq. 16, docs/design.md#m2) and the exact common-point test (#m3)."""

import itertools
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import radialopt as ro
from tests.problems import scene, sphere_sets


def pairwise_meet(centers, radii, tol=1e-9):
    """Direct statement of 'every pair of spheres meets': |ri - rj| <= d <= ri + rj."""
    for i, j in itertools.combinations(range(len(radii)), 2):
        d = np.linalg.norm(centers[i] - centers[j])
        if not (abs(radii[i] - radii[j]) <= d + tol and d <= radii[i] + radii[j] + tol):
            return False
    return True


@given(sphere_sets(min_n=2, max_n=7))
def test_rows_are_hesse_normal_form_and_membership_is_pairwise_meeting(spheres):
    P = ro.RestrictionPolytope.from_spheres(spheres)
    n = len(spheres)
    assert P.A.shape == (3 * math.comb(n, 2), n)
    np.testing.assert_allclose(np.linalg.norm(P.A, axis=1), 1.0, atol=1e-15)
    centers = np.array([s.center for s in spheres])
    radii = np.array([s.radius for s in spheres])
    assert P.contains(radii) == pairwise_meet(centers, radii)


@given(sphere_sets(min_n=2, max_n=6), st.integers(0, 10_000))
def test_normalized_polytope_is_the_same_set_in_sd(spheres, seed):
    P = ro.RestrictionPolytope.from_spheres(spheres)
    Pd = P.normalized()
    sig = P.sigmas
    assert Pd.space == "Sd"
    np.testing.assert_allclose(np.linalg.norm(Pd.A, axis=1), 1.0, atol=1e-12)
    rng = np.random.default_rng(seed)
    pts = rng.uniform(0, 20, size=(200, len(spheres)))
    np.testing.assert_array_equal(P.contains(pts, tol=0), Pd.contains(pts / sig, tol=0))
    # the signed Hesse distance to each hyperplane scales with the row norm of A diag(sigma)
    k = rng.integers(len(P.b))
    x = pts[0]
    raw = P.b[k] - P.A[k] @ x
    norm = np.linalg.norm(P.A[k] * sig)
    assert Pd.b[k] - Pd.A[k] @ (x / sig) == pytest.approx(raw / norm, rel=1e-9, abs=1e-12)


def test_nonnegative_radii_follow_from_the_rows():
    rng = np.random.default_rng(3)
    centers, *_ = scene(rng, 4)
    P = ro.RestrictionPolytope.from_centers(centers)
    pts = rng.uniform(-10, 10, size=(20000, 4))
    inside = pts[P.contains(pts, tol=0)]
    assert len(inside) > 10
    assert np.all(inside >= 0)


def test_row_labels_name_kind_and_pair():
    P = ro.RestrictionPolytope.from_centers(np.eye(3))
    assert P.row_name(0) == "chi(0,1)"
    assert [P.row_name(k) for k in range(3)] == ["chi(0,1)", "alpha(0,1)", "beta(0,1)"]
    # beta(0,1): r0 - r1 <= d  -> violated when sphere 0 swallows sphere 1
    # all centre distances are sqrt(2) = 1.414: only r0 - r1 = 1.5 breaks a restriction
    assert P.violated_rows([5.0, 3.5, 4.2]) == ["beta(0,1)"]
    assert P.violated_rows([0.5, 0.5, 4.2]) == ["chi(0,1)", "alpha(0,2)", "alpha(1,2)"]


def test_polytope_is_only_necessary_counterexample():
    # docs/design.md#m3: equilateral triangle of side 2, all radii 1.1
    c = np.array([[0, 0, 0], [2, 0, 0], [1, math.sqrt(3), 0]], dtype=float)
    spheres = ro.make_spheres(c, [1.1] * 3, 0.1)
    assert ro.RestrictionPolytope.from_spheres(spheres).contains([1.1] * 3)
    assert not ro.common_point_exists(spheres)
    circumradius = 2 / math.sqrt(3)
    assert ro.common_point_exists(ro.make_spheres(c, [circumradius] * 3, 0.1))
    assert ro.common_point_exists(ro.make_spheres(c, [circumradius + 0.01] * 3, 0.1))


def _brute_force_common_point(centers, radii, rng):
    """Independent reference: minimise sum (|x - c_i| - r_i)^2 from many starts (Gauss-Newton)."""
    best = np.inf
    for _ in range(30):
        x = rng.uniform(-8, 8, 3)
        for _ in range(200):
            diff = x - centers
            dist = np.linalg.norm(diff, axis=1)
            res = dist - radii
            J = diff / np.maximum(dist, 1e-12)[:, None]
            step, *_ = np.linalg.lstsq(J, -res, rcond=None)
            x = x + step
            if np.linalg.norm(step) < 1e-14:
                break
        best = min(best, float(np.sum((np.linalg.norm(x - centers, axis=1) - radii) ** 2)))
    return best


@pytest.mark.parametrize("n", [3, 4])
def test_common_point_exists_for_true_ranges_and_not_for_perturbed(n):
    rng = np.random.default_rng(10 + n)
    for _ in range(20):
        centers, robot, _, _ = scene(rng, n)
        radii = np.linalg.norm(centers - robot, axis=1)
        assert ro.common_point_exists(ro.make_spheres(centers, radii, 0.1))
        bumped = radii.copy()
        bumped[rng.integers(n)] += 0.05
        exists = ro.common_point_exists(ro.make_spheres(centers, bumped, 0.1))
        residual = _brute_force_common_point(centers, bumped, rng)
        if n == 4:  # four generic spheres with one radius changed never share a point
            assert not exists
            assert residual > 1e-10
        elif not exists:  # three spheres: disagreement would show up as a zero residual
            assert residual > 1e-10


def test_common_point_degenerate_centres_collinear_and_coplanar():
    axis = np.array([[0, 0, 0], [1, 0, 0], [3, 0, 0]], dtype=float)
    p = np.array([1.5, 0.7, -0.2])
    r = np.linalg.norm(axis - p, axis=1)
    assert ro.common_point_exists(ro.make_spheres(axis, r, 0.1))
    assert not ro.common_point_exists(ro.make_spheres(axis, r + [0, 0, 0.1], 0.1))
    plane = np.array([[0, 0, 1], [2, 0, 1], [0, 3, 1], [2, 3, 1]], dtype=float)
    r4 = np.linalg.norm(plane - p, axis=1)
    assert ro.common_point_exists(ro.make_spheres(plane, r4, 0.1))
    assert not ro.common_point_exists(ro.make_spheres(plane, r4 + [0.05, 0, 0, 0], 0.1))


def test_coincident_centres_raise_naming_the_pair():
    with pytest.raises(ro.RadialError, match=r"centers\[0\] = .* and centers\[2\] = "):
        ro.RestrictionPolytope.from_centers([[1, 1, 1], [0, 0, 0], [1, 1, 1]])
    with pytest.raises(ro.RadialError, match=r"\(1, 3\)"):
        ro.RestrictionPolytope.from_centers([[1, 1, 1]])
    with pytest.raises(ro.RadialError, match=r"centers\[0, 2\] must be finite, got nan"):
        ro.RestrictionPolytope.from_centers([[1, 1, np.nan], [0, 0, 0]])
