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
