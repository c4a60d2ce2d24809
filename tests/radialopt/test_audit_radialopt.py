"""Regression tests for the radialopt audit findings (issue 12): each fails without its fix."""

from __future__ import annotations

import numpy as np
import pytest

import radialopt as ro
from radialopt import errors


def _spheres() -> list[ro.GaussianSphere]:
    return ro.make_spheres([[0, 0, 0], [4, 0, 0], [0, 3, 0.5], [1, 1, 3]], [1.9, 3.4, 2.1, 2.3],
                           [0.1, 0.2, 0.05, 0.3])


# ---------------------------------------------------------------- 1. iterables of spheres
@pytest.mark.parametrize("method", ro.POSITION_METHODS)
def test_estimate_position_accepts_a_generator(method: str) -> None:
    spheres = _spheres()
    ref = ro.estimate_position(spheres, method=method)
    got = ro.estimate_position((s for s in spheres), method=method)
    assert got.status == ref.status
    np.testing.assert_allclose(got.position, ref.position)


def test_project_radii_check_accepts_a_generator() -> None:
    spheres = _spheres()
    ref = ro.project_radii(spheres, check=True)
    got = ro.project_radii((s for s in spheres), check=True)
    np.testing.assert_allclose(got.radii, ref.radii)


# ---------------------------------------------------------------- 2. vertex enumeration size guard
def _random_spheres(n: int, seed: int) -> list[ro.GaussianSphere]:
    rng = np.random.default_rng(seed)
    c = rng.uniform(0, 10, (n, 3))
    return ro.make_spheres(c, rng.uniform(1, 5, n), np.full(n, 0.1))


def test_enumerate_vertices_refuses_more_than_max_vertex_spheres() -> None:
    n = ro.MAX_VERTEX_SPHERES + 1
    poly = ro.RestrictionPolytope.from_centers(np.random.default_rng(0).uniform(0, 10, (n, 3)))
    with pytest.raises(errors.TooManySpheresError, match=rf"{n} spheres.*MAX_VERTEX_SPHERES = "
                       rf"{ro.MAX_VERTEX_SPHERES}.*check=False.*cvxpy"):
        ro.enumerate_vertices(poly)


def test_enumerate_vertices_still_runs_at_max_vertex_spheres() -> None:
    n = ro.MAX_VERTEX_SPHERES
    poly = ro.RestrictionPolytope.from_centers(np.random.default_rng(1).uniform(0, 10, (n, 3)))
    enum = ro.enumerate_vertices(poly)
    assert len(enum.vertices) > 0
    assert poly.contains(enum.vertices[0], 1e-6)


@pytest.mark.parametrize("kwargs", [dict(check=True), dict(check="exact"), dict(method="vertices")])
def test_project_radii_with_enumeration_refuses_too_many_spheres(kwargs: dict) -> None:
    spheres = _random_spheres(10, 2)
    with pytest.raises(errors.TooManySpheresError, match=r"10 spheres.*MAX_VERTEX_SPHERES"):
        ro.project_radii(spheres, **kwargs)
    sol = ro.project_radii(spheres)  # check=False handles any size
    poly = ro.RestrictionPolytope.from_centers([s.center for s in spheres])
    assert poly.contains(sol.radii, 1e-6)


# ---------------------------------------------------------------- 3. bounded memory: chunked batches
def _batch_equal(a: object, b: object) -> None:
    from dataclasses import fields

    assert type(a) is type(b)
    for f in fields(a):
        np.testing.assert_array_equal(getattr(a, f.name), getattr(b, f.name), err_msg=f.name)


@pytest.mark.parametrize("fn, m", [(ro.meet2_batch, 2), (ro.meet3_batch, 3), (ro.meet4_batch, 4)])
def test_meet_batches_chunked_equal_unchunked(monkeypatch: pytest.MonkeyPatch, fn: object, m: int) -> None:
    import radialopt.conformal as conformal

    rng = np.random.default_rng(3)
    k = 1003
    c = rng.uniform(0, 10, (k, m, 3))
    r2 = rng.uniform(1, 5, (k, m)) ** 2
    c[5, 1] = c[5, 0]  # a coincident instance (NaN rows) inside a later chunk too
    c[777, 1] = c[777, 0]
    whole = fn(c, r2)
    monkeypatch.setattr(conformal, "MEET_CHUNK", 64)
    chunked = fn(c, r2)
    _batch_equal(whole, chunked)
    # each row equals the meet of that instance alone (the obvious per-row reference)
    for i in (0, 5, 63, 64, 777, k - 1):
        _batch_equal(fn(c[i:i + 1], r2[i:i + 1]), type(whole)(
            **{f: getattr(whole, f)[i:i + 1] for f in whole.__dataclass_fields__}))


def test_total_density_chunked_equals_a_per_point_loop(monkeypatch: pytest.MonkeyPatch) -> None:
    import math

    import radialopt.spheres as spheres_mod

    rng = np.random.default_rng(4)
    centers = rng.uniform(0, 10, (7, 3))
    truth = np.array([4.0, 5.0, 6.0])
    spheres = ro.make_spheres(centers, np.linalg.norm(centers - truth, axis=1) + 0.05, np.full(7, 0.5))
    pts = np.vstack([truth, rng.uniform(0, 10, (200, 3))])
    monkeypatch.setattr(spheres_mod, "DENSITY_CHUNK_ELEMENTS", 3 * 7 * 13)  # 13 points per chunk
    got = ro.total_density(spheres, pts)
    ref = [math.exp(-0.5 * sum(((math.dist(p, s.center) - s.radius) / s.sigma) ** 2 for s in spheres))
           for p in pts]
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=0)
    assert ro.total_density(spheres, truth) == pytest.approx(math.exp(-0.5 * 7 * 0.1**2), rel=1e-12)


def test_meet4_batch_memory_stays_near_the_input_size(monkeypatch: pytest.MonkeyPatch) -> None:
    import tracemalloc

    import radialopt.conformal as conformal

    rng = np.random.default_rng(5)
    c = rng.uniform(0, 10, (200_000, 4, 3))
    r2 = rng.uniform(1, 5, (200_000, 4))
    monkeypatch.setattr(conformal, "MEET_CHUNK", 10_000)
    tracemalloc.start()
    try:
        ro.meet4_batch(c, r2)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # unchunked: about 6x the input (SVD, solve and distance temporaries of every row at once)
    assert peak < 2.5 * (c.nbytes + r2.nbytes)


def test_total_density_memory_is_bounded_by_the_chunk(monkeypatch: pytest.MonkeyPatch) -> None:
    import tracemalloc

    import radialopt.spheres as spheres_mod

    rng = np.random.default_rng(6)
    spheres = ro.make_spheres(rng.uniform(0, 10, (1000, 3)), rng.uniform(1, 5, 1000), np.full(1000, 0.3))
    pts = rng.uniform(0, 10, (3000, 3))
    monkeypatch.setattr(spheres_mod, "DENSITY_CHUNK_ELEMENTS", 300_000)
    tracemalloc.start()
    try:
        ro.total_density(spheres, pts)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    unchunked_temporary = pts.shape[0] * len(spheres) * 3 * 8  # the (points, spheres, 3) difference
    assert peak < unchunked_temporary / 4


# ---------------------------------------------------------------- 4. outside_region is no success
def test_outside_region_is_not_a_success_status() -> None:
    region = ro.Region([5.0, 5, 5], [6.0, 6, 6])
    est = ro.estimate_position(_spheres(), region=region)
    assert est.status == "outside_region"
    assert not region.contains(est.position)
    assert est.status not in ro.POSITION_SUCCESS


@pytest.mark.parametrize("method", ro.POSITION_METHODS)
def test_success_positions_lie_in_the_region(method: str) -> None:
    """Exact ranges from a known point: a success status must put the position in the region."""
    centers = np.array([[1.0, 1, 0.5], [9, 2, 1], [3, 9, 1.5], [5, 5, 8]])
    truth = np.array([4.0, 4.0, 3.0])
    spheres = ro.make_spheres(centers, np.linalg.norm(centers - truth, axis=1), np.full(4, 0.05))
    for lo, hi in (([0.0, 0, 0], [8.0, 8, 8]), ([20.0, 20, 20], [30.0, 30, 30])):
        region = ro.Region(lo, hi)
        est = ro.estimate_position(spheres, method=method, region=region)
        if est.status in ro.POSITION_SUCCESS:
            assert region.contains(est.position, tol=1e-9)
            np.testing.assert_allclose(est.position, truth, atol=1e-6)


# ---------------------------------------------------------------- 5. conformal_sphere radius sign
def test_conformal_sphere_rejects_a_negative_radius() -> None:
    with pytest.raises(errors.NegativeRadiusError, match=r"radius = -1\.0"):
        ro.conformal_sphere([0.0, 0, 0], -1.0)
    # a non-negative radius still works: e_inf coefficient 1/2 (|X|^2 - r^2) of eq. 4
    s = ro.conformal_sphere([1.0, 2.0, 2.0], 1.5)
    assert s[4] == pytest.approx(0.5 * (9.0 - 2.25))


# ---------------------------------------------------------------- 6. negative indices do not wrap
def test_row_name_rejects_a_negative_index() -> None:
    poly = ro.RestrictionPolytope.from_centers(np.eye(3))
    with pytest.raises(errors.RadialError, match=r"k = -1"):
        poly.row_name(-1)
    assert poly.row_name(len(poly.kinds) - 1).endswith("(1,2)")  # last pair of 3 spheres


def test_fix_radius_rejects_a_negative_index() -> None:
    with pytest.raises(errors.RadialError, match=r"i = -1"):
        ro.RadialProblem(4).fix_radius(-1, 2.0)


# ---------------------------------------------------------------- 7. bound_radii / fix_radius values
@pytest.mark.parametrize("lo, hi, name", [(True, 10.0, "lo"), (0.0, True, "hi"),
                                          (0.0, np.array([True] * 4), "hi"), (float("nan"), 1.0, "lo"),
                                          (0.0, 1e300, "hi"), (0.0, [1.0, 2.0], "hi"), (0.0, "3", "hi")])
def test_bound_radii_rejects_bad_bounds(lo: object, hi: object, name: str) -> None:
    with pytest.raises(errors.RadialError, match=rf"\b{name}\b"):
        ro.RadialProblem(4).bound_radii(lo, hi)


def test_fix_radius_rejects_a_huge_value() -> None:
    with pytest.raises(errors.OutOfRangeError, match=r"value = 1e\+308"):
        ro.RadialProblem(4).fix_radius(1, 1e308)


def test_infeasible_added_constraints_are_named() -> None:
    spheres = _spheres()  # centres 0 and 1 are 4 m apart: radii 0.1 and 0.1 cannot reach
    with pytest.raises(errors.SolverError,
                       match=r"fix_radius\(i=0, value=0\.1\).*fix_radius\(i=1, value=0\.1\)"):
        ro.RadialProblem(4).fix_radius(0, 0.1).fix_radius(1, 0.1).solve(spheres)
    with pytest.raises(errors.SolverError, match=r"bound_radii\(lo=0\.0, hi=0\.5\)"):
        ro.RadialProblem(4).bound_radii(0.0, 0.5).solve(spheres)


def test_bound_radii_keeps_open_sides_and_arrays() -> None:
    spheres = _spheres()
    sol = ro.RadialProblem(4).bound_radii(-np.inf, [10.0, 10.0, 10.0, np.inf]).solve(spheres)
    # the measured radii already satisfy the polytope (feasible), so the projection keeps them
    np.testing.assert_allclose(sol.radii, [1.9, 3.4, 2.1, 2.3], atol=1e-6)
    sol = ro.RadialProblem(4).bound_radii(0.0, 3.0).solve(spheres)
    assert np.all(sol.radii <= 3.0 + 1e-6)


# ---------------------------------------------------------------- 8. empty / unknown solver names
@pytest.mark.parametrize("solver", ["", " ", "NO_SUCH_SOLVER"])
def test_project_radii_rejects_an_empty_or_unknown_solver(solver: str) -> None:
    with pytest.raises(errors.UnknownMethodError, match=rf"solver = {solver!r}"):
        ro.project_radii(_spheres(), method="cvxpy", solver=solver)


def test_project_radii_default_solver_is_still_clarabel() -> None:
    assert ro.project_radii(_spheres(), method="cvxpy").solver == "CLARABEL"
    assert ro.project_radii(_spheres(), method="cvxpy", solver="clarabel").solver == "CLARABEL"


# ---------------------------------------------------------------- 9. messages name `centers`
def test_crlb_singular_names_centers_and_position() -> None:
    with pytest.raises(errors.SingularFisherError, match=r"position = \[1\.0, 1\.2, 1\.1\].*centers = "
                       r"\[\[-1\.0, -1\.0, -1\.0\]"):
        ro.crlb(np.full((4, 3), -1.0), [0.1] * 4, [1.0, 1.2, 1.1])


def test_from_centers_coincident_message_uses_the_argument_name() -> None:
    with pytest.raises(errors.CoincidentCentersError, match=r"centers\[0\] = \[0\.0, 0\.0, 0\.0\] and "
                       r"centers\[2\] = \[0\.0, 0\.0, 0\.0\]"):
        ro.RestrictionPolytope.from_centers([[0.0, 0, 0], [1.0, 0, 0], [0.0, 0, 0]])
