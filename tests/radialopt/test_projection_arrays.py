"""project_radii(centers=, radii=, sigmas=): the array form, its checks (a plain-Python fast
path for float64 arrays and real_array for the rest, same errors), and GaussianSphere's fast
path against its full checks."""

import re

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import radialopt as ro
from radialopt.spheres import checked_arrays
from tests.problems import sphere_arrays, sphere_sets


@given(sphere_sets(min_n=2, max_n=8))
def test_array_form_gives_the_spheres_answer(spheres):
    c, r, s = sphere_arrays(spheres)
    a = ro.project_radii(centers=c, radii=r, sigmas=s)
    b = ro.project_radii(spheres)
    np.testing.assert_array_equal(a.radii, b.radii)
    assert (a.status, a.active_rows, a.density) == (b.status, b.active_rows, b.density)


def test_array_form_other_methods_lists_and_scalar_sigma():
    rng = np.random.default_rng(3)
    c = rng.uniform(-2, 2, (5, 3))
    r = rng.uniform(0, 4, 5)
    spheres = ro.make_spheres(c, r, 0.1)
    for method in ("active_set", "cvxpy", "paper"):
        a = ro.project_radii(centers=c, radii=r, sigmas=0.1, method=method)
        np.testing.assert_allclose(a.radii, ro.project_radii(spheres, method=method).radii, atol=1e-12)
    lists = ro.project_radii(centers=c.tolist(), radii=r.tolist(), sigmas=[0.1] * 5, check=True)
    np.testing.assert_array_equal(lists.radii, ro.project_radii(spheres).radii)
    ints = ro.project_radii(centers=np.arange(12).reshape(4, 3), radii=np.arange(4), sigmas=np.ones(4, int))
    assert ints.status == "optimal"
    big_endian = ro.project_radii(centers=c.astype(">f8"), radii=r.astype(">f8"),
                                  sigmas=np.full(5, 0.1, ">f8"))
    np.testing.assert_array_equal(big_endian.radii, ro.project_radii(spheres).radii)


C = np.array([[0.0, 0, 0], [1, 0, 0], [0, 2, 0], [0, 0, 3]])
R = np.array([1.0, 1.0, 1.0, 1.0])
S = np.array([0.1, 0.1, 0.1, 0.1])


def with_value(arr, idx, value):
    out = arr.copy()
    out[idx] = value
    return out


BAD = [
    (dict(centers=with_value(C, (1, 2), np.nan)), ro.RadialError, r"centers[1, 2] must be finite, got nan"),
    (dict(centers=with_value(C, (2, 0), 2e9)), ro.RadialError,
     r"centers[2, 0] must be <= 1e+09 in magnitude, got 2000000000.0"),
    (dict(radii=with_value(R, 2, -1.0)), ro.RadialError, r"radii[2] = -1.0 must be >= 0"),
    (dict(radii=with_value(R, 3, np.inf)), ro.RadialError, r"radii[3] must be finite, got inf"),
    (dict(sigmas=with_value(S, 1, 0.0)), ro.RadialError, r"sigmas[1] = 0.0 must be > 0"),
    (dict(sigmas=with_value(S, 0, 1e-20)), ro.RadialError, r"sigmas[0] = 1e-20 is outside"),
    (dict(sigmas=with_value(S, 2, 1e20)), ro.RadialError, r"sigmas[2] = 1e+20 is outside"),
    (dict(sigmas=with_value(S, 2, -np.inf)), ro.RadialError, r"sigmas[2] must be finite, got -inf"),
    (dict(radii=R[:3]), ro.RadialError, "radii must have shape (4,) like centers"),
    (dict(sigmas=S[:3]), ro.RadialError, "sigmas must be a scalar or have shape (4,)"),
    (dict(centers=C[:, :2]), ro.RadialError, "centers must have shape (n, 3)"),
    (dict(centers=C[:1], radii=R[:1], sigmas=S[:1]), ro.RadialError, "at least 2"),
    (dict(radii=R > 0), ro.RadialError, "booleans"),
    (dict(centers=with_value(C, 1, 0.0)), ro.RadialError, "centres 0 and 1 coincide"),
]


@pytest.mark.parametrize(("change", "error", "message"), BAD)
def test_array_form_bad_input(change, error, message):
    kwargs = dict(centers=C, radii=R, sigmas=S) | change
    with pytest.raises(error, match=re.escape(message)):
        ro.project_radii(**kwargs)
    lists = {k: v.tolist() for k, v in kwargs.items()}  # the slow path says the same
    with pytest.raises(error, match=re.escape(message)):
        ro.project_radii(**lists)


def test_array_form_argument_errors():
    with pytest.raises(ro.RadialError, match="not both"):
        ro.project_radii(ro.make_spheres(C, R, S), centers=C, radii=R, sigmas=S)
    with pytest.raises(ro.RadialError, match="missing sigmas"):
        ro.project_radii(centers=C, radii=R)
    with pytest.raises(ro.RadialError, match="needs spheres"):
        ro.project_radii()


finite = st.floats(-1e3, 1e3)
special = st.sampled_from([np.nan, np.inf, -np.inf, -1.0, 0.0, 1e-30, 1e30, 2e9, -2e9, 5.0])


@given(st.integers(2, 6), st.data())
def test_fast_and_slow_checks_agree(n, data):
    """checked_arrays on float64 arrays (plain-Python fast path) raises the same error with the
    same message as on lists (real_array), or returns the same arrays."""
    c = np.array(data.draw(st.lists(st.lists(finite, min_size=3, max_size=3), min_size=n, max_size=n)))
    r = np.abs(np.array(data.draw(st.lists(finite, min_size=n, max_size=n))))
    s = np.array(data.draw(st.lists(st.floats(1e-3, 10.0), min_size=n, max_size=n)))
    which = data.draw(st.sampled_from(["c", "r", "s", "none"]))
    value = data.draw(special)
    if which == "c":
        c[data.draw(st.integers(0, n - 1)), data.draw(st.integers(0, 2))] = value
    elif which == "r":
        r[data.draw(st.integers(0, n - 1))] = value
    elif which == "s":
        s[data.draw(st.integers(0, n - 1))] = value
    try:
        fast = checked_arrays(c, r, s)
    except ro.RadialError as exc:
        with pytest.raises(type(exc), match=re.escape(str(exc))):
            checked_arrays(c.tolist(), r.tolist(), s.tolist())
    else:
        slow = checked_arrays(c.tolist(), r.tolist(), s.tolist())
        for a, b in zip(fast, slow, strict=True):
            np.testing.assert_array_equal(a, b)


# --- GaussianSphere: the fast path and the full checks --------------------------------------
@pytest.mark.parametrize("center", [np.array([1.0, 2.0, 3.0]), [1.0, 2.0, 3.0], (1.0, 2.0, 3.0),
                                    [1, 2, 3], np.array([1, 2, 3]), np.array([1.0, 2.0, 3.0], np.float32)])
@pytest.mark.parametrize("radius", [2.0, np.float64(2.0), 2, np.float32(2.0)])
def test_sphere_fast_and_slow_paths_build_the_same_sphere(center, radius):
    s = ro.GaussianSphere(center, radius, np.float64(0.5))
    assert s == ro.GaussianSphere(np.array([1.0, 2.0, 3.0]), 2.0, 0.5)
    assert type(s.radius) is float and type(s.sigma) is float
    assert s.center.dtype == np.float64 and not s.center.flags.writeable


def test_sphere_center_is_a_copy():
    c = np.array([1.0, 2.0, 3.0])
    s = ro.GaussianSphere(c, 1.0, 0.1)
    c[0] = 9.0
    assert s.center[0] == 1.0


@pytest.mark.parametrize(("args", "error", "message"), [
    ((np.array([0.0, np.nan, 0.0]), 1.0, 0.1), ro.RadialError, "center[1] must be finite, got nan"),
    (([0.0, 0.0, 2e9], 1.0, 0.1), ro.RadialError,
     "center[2] must be <= 1e+09 in magnitude, got 2000000000.0"),
    ((np.zeros(3), -1.0, 0.1), ro.RadialError, "radius = -1.0 must be >= 0"),
    ((np.zeros(3), np.float64(np.nan), 0.1), ro.RadialError, "radius must be finite, got nan"),
    ((np.zeros(3), 2e9, 0.1), ro.RadialError, "radius must be <= 1e+09 in magnitude, got 2000000000.0"),
    ((np.zeros(3), 1.0, 0.0), ro.RadialError, "sigma = 0.0 must be > 0"),
    ((np.zeros(3), 1.0, np.inf), ro.RadialError, "sigma must be finite, got inf"),
    ((np.zeros(3), 1.0, 1e101), ro.RadialError, "sigma must be <= 1e+100 in magnitude, got 1e+101"),
    ((np.zeros(3), True, 0.1), ro.RadialError, "radius must be a real number"),
    ((np.zeros(2), 1.0, 0.1), ro.RadialError, "center must have shape (3,)"),
    (([0.0, 0.0, np.inf], 1.0, 0.1), ro.RadialError, "center[2] must be finite, got inf"),
    ((np.zeros(3), 1.0, np.float64(-0.5)), ro.RadialError, "sigma = -0.5 must be > 0"),
])
def test_sphere_bad_input_on_fast_path_types(args, error, message):
    with pytest.raises(error, match=re.escape(message)):
        ro.GaussianSphere(*args)
