"""GaussianSphere, densities (eqs. 11-14, 18-20) and the conformal sphere (eq. 4, docs/design.md#m1)."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import radialopt as ro
from radialopt.spheres import conformal_inner, conformal_sphere

finite = st.floats(-100, 100, allow_nan=False, allow_infinity=False)
point = st.tuples(finite, finite, finite)


@given(point, st.floats(0, 50), st.floats(1e-3, 10), point)
def test_density_is_eq_12(center, radius, sigma, x):
    s = ro.GaussianSphere(center, radius, sigma)
    dist = math.dist(center, x)
    expected = math.exp(-((dist - radius) ** 2) / (2 * sigma**2))
    assert s.density(x) == pytest.approx(expected, rel=1e-12, abs=1e-300)
    assert 0.0 <= s.density(x) <= 1.0


def test_density_is_one_on_the_surface_and_vectorised():
    s = ro.GaussianSphere((1.0, 2.0, 3.0), 2.0, 0.1)
    dirs = np.random.default_rng(0).standard_normal((10, 3))
    pts = s.center + 2.0 * dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    np.testing.assert_allclose(ro.density(s, pts), 1.0, rtol=0, atol=1e-12)
    assert ro.density(s, pts).shape == (10,)


@given(st.lists(st.tuples(point, st.floats(0, 20), st.floats(0.01, 5)), min_size=1, max_size=6),
       point)
def test_total_density_is_the_product_and_eq_20(raw, x):
    spheres = [ro.GaussianSphere(c, r, s) for c, r, s in raw]
    product = math.prod(s.density(x) for s in spheres)
    assert ro.total_density(spheres, x) == pytest.approx(product, rel=1e-9, abs=1e-300)
    # eq. 20: radial form with r_x = |x - X_i|
    r_x = [math.dist(c, x) for c, _, _ in raw]
    radial = ro.radial_density(r_x, [r for _, r, _ in raw], [s for _, _, s in raw])
    assert radial == pytest.approx(product, rel=1e-9, abs=1e-300)


@given(point, st.floats(0, 30), point, st.floats(0, 30))
def test_conformal_inner_product_gives_centre_distance(c1, r1, c2, r2):
    s1, s2 = conformal_sphere(c1, r1), conformal_sphere(c2, r2)
    d2 = r1**2 + r2**2 - 2 * conformal_inner(s1, s2)
    assert d2 == pytest.approx(math.dist(c1, c2) ** 2, rel=1e-9, abs=1e-7)
    # a point (radius 0) lies on the sphere iff its inner product with the sphere is 0
    assert conformal_inner(s1, s1) == pytest.approx(r1**2, rel=1e-9, abs=1e-7)


@pytest.mark.parametrize(
    ("kwargs", "error", "fragment"),
    [
        ({"center": (0, 0, np.nan), "radius": 1, "sigma": 1}, ro.RadialError, "[2] must be finite, got nan"),
        ({"center": (0, 0, 0), "radius": np.inf, "sigma": 1}, ro.RadialError,
         "radius must be finite, got inf"),
        ({"center": (0, 0, 0), "radius": 1, "sigma": 0.0}, ro.RadialError, "sigma = 0.0 must be > 0"),
        ({"center": (0, 0, 0), "radius": 1, "sigma": -2}, ro.RadialError, "sigma = -2.0 must be > 0"),
        ({"center": (0, 0, 0), "radius": -1, "sigma": 1}, ro.RadialError, "radius = -1.0 must be >= 0"),
        ({"center": (0, 0), "radius": 1, "sigma": 1}, ro.RadialError, "shape (3,), got shape (2,)"),
        ({"center": (0, 0, 0), "radius": "a", "sigma": 1}, ro.RadialError, "radius must be a real number"),
    ],
)
def test_bad_sphere_raises_specific_error_naming_the_value(kwargs, error, fragment):
    with pytest.raises(error, match=None) as info:
        ro.GaussianSphere(**kwargs)
    assert isinstance(info.value, ro.RadialError) and isinstance(info.value, ValueError)
    assert fragment in str(info.value)


def test_sphere_is_frozen_and_center_read_only():
    s = ro.GaussianSphere([1, 2, 3], 1, 1)
    with pytest.raises(AttributeError):
        s.radius = 2.0  # type: ignore[misc]
    with pytest.raises(ValueError):
        s.center[0] = 5.0
