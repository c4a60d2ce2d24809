"""The small-instance active set (plain-Python dual active set) and the unchecked internal
route: same answers as the checked public route and as the NNLS / vertex references."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import radialopt as ro
import radialopt.projection as proj
import radialopt.projection.project as project_module
from radialopt._ldp import _least_distance_dense
from radialopt._projection_types import _Problem
from radialopt.projection import project_radii_unchecked
from tests.problems import sphere_arrays, sphere_sets


@st.composite
def grid_spheres(draw, min_n: int = 2, max_n: int = 6):
    """Degenerate instances: integer centres, integer radii, equal or doubled sigmas (ties,
    dependent active rows, several optimal multipliers)."""
    n = draw(st.integers(min_n, max_n))
    pts = draw(st.lists(st.tuples(*[st.integers(-2, 2)] * 3), min_size=n, max_size=n, unique=True))
    radii = draw(st.lists(st.integers(0, 4), min_size=n, max_size=n))
    sigmas = draw(st.lists(st.sampled_from([1.0, 2.0]), min_size=n, max_size=n))
    return ro.make_spheres(np.array(pts, dtype=float), np.array(radii, dtype=float), np.array(sigmas))


@given(st.one_of(sphere_sets(min_n=2, max_n=8), grid_spheres(max_n=7)))
def test_checked_and_unchecked_routes_give_the_same_answer(spheres):
    for method in ("active_set", "paper") if len(spheres) <= 5 else ("active_set",):
        checked = ro.project_radii(spheres, method=method)
        trusted = project_radii_unchecked(*sphere_arrays(spheres), method=method)
        np.testing.assert_allclose(trusted.radii, checked.radii, rtol=0, atol=1e-12)
        assert trusted.status == checked.status
        assert trusted.active_rows == checked.active_rows
        assert trusted.method == checked.method == method
        assert trusted.normalized_displacement == pytest.approx(checked.normalized_displacement,
                                                                rel=1e-12, abs=1e-12)


@given(st.one_of(sphere_sets(min_n=2, max_n=6), grid_spheres(max_n=6)))
def test_small_core_equals_the_nnls_route_and_vertex_enumeration(spheres):
    sol = ro.project_radii(spheres)  # n <= SMALL_CORE_SPHERES: the plain-Python core
    p = _Problem.build(spheres, ro.TOLERANCES)
    z, status = _least_distance_dense(p.G, p.h)  # Lawson-Hanson NNLS + polish, the old core
    assert status == "optimal"
    ref = p.radii + p.sigmas * z
    scale = max(1.0, float(np.abs(p.b).max()))
    np.testing.assert_allclose(sol.radii, ref, rtol=0, atol=1e-9 * scale)
    assert sol.status == "optimal"
    if len(spheres) <= 5:
        vert = ro.project_radii(spheres, method="vertices")
        np.testing.assert_allclose(sol.radii, vert.radii, rtol=0, atol=1e-8 * scale)


def test_small_core_is_the_route_taken_and_its_fallback_gives_the_same_answer(monkeypatch):
    """n <= SMALL_CORE_SPHERES runs _ldp_pairs; when it does not certify, the NNLS route answers."""
    rng = np.random.default_rng(5)
    cases = []
    while len(cases) < 20:
        n = int(rng.integers(2, proj.SMALL_CORE_SPHERES + 1))
        c = rng.uniform(-3, 3, (n, 3))
        r = np.abs(np.linalg.norm(c - rng.uniform(-3, 3, 3), axis=1) + rng.normal(0, 0.8, n))
        s = rng.uniform(0.01, 0.5, n)
        if not ro.RestrictionPolytope.from_centers(c).contains(r):
            cases.append(ro.make_spheres(c, r, s))
    calls = []
    real = project_module._ldp_pairs
    monkeypatch.setattr(project_module, "_ldp_pairs",
                        lambda rows, n, *setup: calls.append(n) or real(rows, n, *setup))
    fast = [ro.project_radii(sp) for sp in cases]
    assert len(calls) == len(cases)
    monkeypatch.setattr(project_module, "_ldp_pairs", lambda rows, n, *setup: None)  # never certifies
    for sp, f in zip(cases, fast, strict=True):
        slow = ro.project_radii(sp)
        np.testing.assert_allclose(f.radii, slow.radii, rtol=0, atol=1e-10)
        assert f.active_rows == slow.active_rows
        assert f.status == slow.status == "optimal"


def test_unchecked_route_still_names_coincident_centres():
    c = np.array([[0.0, 0, 0], [1.0, 0, 0], [1.0, 0, 0]])
    with pytest.raises(ro.RadialError, match="1 and 2"):
        project_radii_unchecked(c, np.array([0.1, 0.1, 0.1]), np.full(3, 0.1))


def test_public_route_keeps_its_input_checks():
    good = ro.make_spheres([[0, 0, 0], [3, 0, 0]], [1.0, 1.0], [0.1, 0.1])
    with pytest.raises(ro.RadialError, match="need at least 2 spheres, got 1"):
        ro.project_radii(good[:1])
    with pytest.raises(ro.RadialError, match=r"spheres\[1\] must be a GaussianSphere, got str"):
        ro.project_radii([good[0], "not a sphere"])
    with pytest.raises(ro.RadialError, match=r"sigmas\[1\] = 1e\-14 is outside the usable range"):
        ro.project_radii([good[0], ro.GaussianSphere([3.0, 0, 0], 1.0, 1e-14)])
    with pytest.raises(ro.RadialError, match="centres 0 and 1 coincide"):
        ro.project_radii([good[0], good[0].with_radius(2.0)])
