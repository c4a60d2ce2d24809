"""enumerate_vertices: the size guard MAX_VERTEX_SPHERES.

From the issue-12 audit of radialopt: each case failed without its fix.
"""

from __future__ import annotations

import numpy as np
import pytest

import radialopt as ro
from radialopt import errors


def test_enumerate_vertices_refuses_more_than_max_vertex_spheres() -> None:
    n = ro.MAX_VERTEX_SPHERES + 1
    poly = ro.RestrictionPolytope.from_centers(np.random.default_rng(0).uniform(0, 10, (n, 3)))
    with pytest.raises(errors.RadialError, match=rf"{n} spheres.*MAX_VERTEX_SPHERES = "
                       rf"{ro.MAX_VERTEX_SPHERES}.*check=False.*cvxpy"):
        ro.enumerate_vertices(poly)


def test_enumerate_vertices_still_runs_at_max_vertex_spheres() -> None:
    n = ro.MAX_VERTEX_SPHERES
    poly = ro.RestrictionPolytope.from_centers(np.random.default_rng(1).uniform(0, 10, (n, 3)))
    enum = ro.enumerate_vertices(poly)
    assert len(enum.vertices) > 0
    assert poly.contains(enum.vertices[0], 1e-6)
