"""total_density in chunks with bounded memory; conformal_sphere's radius sign.

From the issue-12 audit of radialopt: each case failed without its fix.
"""

from __future__ import annotations

import numpy as np
import pytest

import radialopt as ro
from radialopt import errors


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


# ---------------------------------------------------------------- 5. conformal_sphere radius sign
def test_conformal_sphere_rejects_a_negative_radius() -> None:
    with pytest.raises(errors.RadialError, match=r"radius = -1\.0"):
        ro.conformal_sphere([0.0, 0, 0], -1.0)
    # a non-negative radius still works: e_inf coefficient 1/2 (|X|^2 - r^2) of eq. 4
    s = ro.conformal_sphere([1.0, 2.0, 2.0], 1.5)
    assert s[4] == pytest.approx(0.5 * (9.0 - 2.25))
