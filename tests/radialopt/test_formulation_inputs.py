"""RadialProblem.fix_radius / bound_radii: indices and values.

From the issue-12 audit of radialopt: each case failed without its fix.
"""

from __future__ import annotations

import numpy as np
import pytest

import radialopt as ro
from radialopt import errors
from tests.problems import four_spheres


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
    with pytest.raises(errors.RadialError, match=r"value must be <= 1e\+09 in magnitude, got 1e\+308"):
        ro.RadialProblem(4).fix_radius(1, 1e308)


def test_infeasible_added_constraints_are_named() -> None:
    spheres = four_spheres()  # centres 0 and 1 are 4 m apart: radii 0.1 and 0.1 cannot reach
    with pytest.raises(errors.SolverError,
                       match=r"fix_radius\(i=0, value=0\.1\).*fix_radius\(i=1, value=0\.1\)"):
        ro.RadialProblem(4).fix_radius(0, 0.1).fix_radius(1, 0.1).solve(spheres)
    with pytest.raises(errors.SolverError, match=r"bound_radii\(lo=0\.0, hi=0\.5\)"):
        ro.RadialProblem(4).bound_radii(0.0, 0.5).solve(spheres)


def test_bound_radii_keeps_open_sides_and_arrays() -> None:
    spheres = four_spheres()
    sol = ro.RadialProblem(4).bound_radii(-np.inf, [10.0, 10.0, 10.0, np.inf]).solve(spheres)
    # the measured radii already satisfy the polytope (feasible), so the projection keeps them
    np.testing.assert_allclose(sol.radii, [1.9, 3.4, 2.1, 2.3], atol=1e-6)
    sol = ro.RadialProblem(4).bound_radii(0.0, 3.0).solve(spheres)
    assert np.all(sol.radii <= 3.0 + 1e-6)


@pytest.mark.parametrize("lo, message", [
    ([True, False, True, False], "must hold real numbers, not booleans"),
    ([np.nan, 0.0, 0.0, -np.inf], r"lo\[0\] must be finite, got nan"),
    ([[0.0, -np.inf]], "must have 0 or 1 dimension"),
    ([0.0, 0.0, 2e10, -np.inf], r"lo\[2\] must be <= 1e\+09 in magnitude, got 20000000000\.0"),
    ([0.0, -np.inf], r"lo must be a scalar or shape \(4,\), got shape \(2,\)"),
    ([[0.0, 1.0], [2.0]], "lo must be a rectangular array of real numbers"),  # ragged
])
def test_an_open_side_does_not_let_another_defect_through(lo, message) -> None:
    # an infinite entry is an open side; the other entries are still checked as real_array does
    with pytest.raises(ro.RadialError, match=message):
        ro.RadialProblem(4).bound_radii(lo, np.inf)
