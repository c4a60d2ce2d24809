"""estimate_position: iterables of spheres; success statuses only inside the region.

From the issue-12 audit of radialopt: each case failed without its fix.
"""

from __future__ import annotations

import numpy as np
import pytest

import radialopt as ro
from tests.problems import four_spheres


# ---------------------------------------------------------------- 1. iterables of spheres
@pytest.mark.parametrize("method", ro.POSITION_METHODS)
def test_estimate_position_accepts_a_generator(method: str) -> None:
    spheres = four_spheres()
    ref = ro.estimate_position(spheres, method=method)
    got = ro.estimate_position((s for s in spheres), method=method)
    assert got.status == ref.status
    np.testing.assert_allclose(got.position, ref.position)


# ---------------------------------------------------------------- 4. outside_region is no success
def test_outside_region_is_not_a_success_status() -> None:
    region = ro.Region([5.0, 5, 5], [6.0, 6, 6])
    est = ro.estimate_position(four_spheres(), region=region)
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
