"""project_radii: iterables of spheres, the size guard of vertex enumeration, solver names.

From the issue-12 audit of radialopt: each case failed without its fix.
"""

from __future__ import annotations

import numpy as np
import pytest

import radialopt as ro
from radialopt import errors
from tests.problems import four_spheres


def test_project_radii_check_accepts_a_generator() -> None:
    spheres = four_spheres()
    ref = ro.project_radii(spheres, check=True)
    got = ro.project_radii((s for s in spheres), check=True)
    np.testing.assert_allclose(got.radii, ref.radii)


# ---------------------------------------------------------------- 2. vertex enumeration size guard
def _random_spheres(n: int, seed: int) -> list[ro.GaussianSphere]:
    rng = np.random.default_rng(seed)
    c = rng.uniform(0, 10, (n, 3))
    return ro.make_spheres(c, rng.uniform(1, 5, n), np.full(n, 0.1))


@pytest.mark.parametrize("kwargs", [dict(check=True), dict(check="exact"), dict(method="vertices")])
def test_project_radii_with_enumeration_refuses_too_many_spheres(kwargs: dict) -> None:
    spheres = _random_spheres(10, 2)
    with pytest.raises(errors.RadialError, match=r"10 spheres.*MAX_VERTEX_SPHERES"):
        ro.project_radii(spheres, **kwargs)
    sol = ro.project_radii(spheres)  # check=False handles any size
    poly = ro.RestrictionPolytope.from_centers([s.center for s in spheres])
    assert poly.contains(sol.radii, 1e-6)


# ---------------------------------------------------------------- 8. empty / unknown solver names
@pytest.mark.parametrize("solver", ["", " ", "NO_SUCH_SOLVER"])
def test_project_radii_rejects_an_empty_or_unknown_solver(solver: str) -> None:
    with pytest.raises(errors.RadialError, match=rf"solver = {solver!r}"):
        ro.project_radii(four_spheres(), method="cvxpy", solver=solver)


def test_project_radii_default_solver_is_still_clarabel() -> None:
    assert ro.project_radii(four_spheres(), method="cvxpy").solver == "CLARABEL"
    assert ro.project_radii(four_spheres(), method="cvxpy", solver="clarabel").solver == "CLARABEL"
