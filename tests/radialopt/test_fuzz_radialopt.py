"""Fuzz every public entry point of radialopt with nasty inputs.

For each entry point a valid baseline call is corrupted in one argument: the whole argument
is replaced by a nasty value (NaN, inf, +-1e308, 1e-300, negative, zero, huge ints, bool,
None, str, complex, wrong shapes, empty arrays, ...), or one element of an array argument is.
The call must either raise :class:`radialopt.RadialError` with a message naming the argument,
or return a result that is finite and satisfies its status's constraints.  Any other
exception fails the test.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import radialopt as ro

CENTERS = np.array([[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 3.0, 0.5], [1.0, 1.0, 3.0]])
TRUTH = np.array([1.0, 1.2, 1.1])
RADII = np.linalg.norm(CENTERS - TRUTH, axis=1) + np.array([0.05, -0.03, 0.02, 0.4])
SIGMAS = np.array([0.1, 0.2, 0.05, 0.3])

NASTY_SCALARS = [math.nan, math.inf, -math.inf, 1e308, -1e308, 1e-300, -1e-300, -1.0, 0.0, 1e154,
                 10**30, -(10**30), True, False, None, "3", 1 + 2j, np.float64(np.nan), 2.5]
NASTY_WHOLE = NASTY_SCALARS + [[], np.zeros((0, 3)), [[1.0, 2.0]], np.full((2, 2), np.nan),
                               np.ones((2, 3, 4)), [1.0, "x", 2.0], np.array([1 + 1j, 2.0]),
                               object(), {"a": 1}, np.zeros(5), -np.ones((4, 3))]


def spheres_of(c=CENTERS, r=RADII, s=SIGMAS):
    return [ro.GaussianSphere(ci, ri, si) for ci, ri, si in zip(c, r, s, strict=True)]


def polytope():
    return ro.RestrictionPolytope.from_centers(CENTERS[:3])


def enumeration():
    return ro.enumerate_vertices(polytope())


def finite(x) -> bool:
    return bool(np.all(np.isfinite(np.asarray(x, dtype=np.float64))))


# ---- result checks: what a returned value must satisfy -----------------------------------

def check_projection(sol, spheres) -> None:
    assert sol.status in ro.STATUSES
    if sol.status in ("optimal", "optimal_inaccurate"):
        c = np.array([s.center for s in spheres])
        P = ro.RestrictionPolytope.from_centers(c)
        scale = max(1.0, float(np.abs(P.b).max()), float(np.abs(sol.radii).max()))
        assert finite(sol.radii) and finite(sol.density)
        rounding = 1e-15 * max(s.radius for s in spheres)
        tol = (1e-9 if sol.status == "optimal" else 1e-6) * scale + rounding
        assert P.contains(sol.radii, tol=tol)


def check_position(est, spheres) -> None:
    assert est.status in ro.POSITION_STATUSES
    if est.status in ("ok", "ambiguous", "outside_region"):
        assert finite(est.position) and 0.0 <= est.density <= 1.0
        c = np.array([s.center for s in spheres])
        spread = max(np.linalg.norm(c - c.mean(axis=0), axis=1).max(), 1e-300)
        assert np.linalg.norm(est.position - c.mean(axis=0)) <= 1e3 * spread * (1 + 1e-9)
        assert finite(est.covariance)


def check_density(v) -> None:
    arr = np.asarray(v, dtype=np.float64)
    assert finite(arr) and np.all((arr >= 0) & (arr <= 1))


def check_meet(res) -> None:
    for f in dataclasses.fields(res):
        v = getattr(res, f.name)
        if isinstance(v, (np.ndarray, float)) and np.asarray(v).dtype.kind == "f":
            assert not np.any(np.isinf(v)), f.name


def check_batch_meet(res) -> None:
    st_ = np.asarray(res.status)
    assert np.all(st_ >= 0)
    for f in dataclasses.fields(res):
        v = getattr(res, f.name)
        if isinstance(v, np.ndarray) and v.dtype.kind == "f":
            assert not np.any(np.isinf(v)), f.name


def check_matrix(m) -> None:
    m = np.asarray(m)
    assert m.shape == (3, 3) and finite(m)
    np.testing.assert_allclose(m, m.T, rtol=1e-9, atol=1e-12 * np.abs(m).max())


def check_certificate(cert) -> None:
    assert cert.method in ro.CERTIFICATE_METHODS
    if cert.certified:
        assert finite(cert.lower_bound)


def check_options(obj) -> None:
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        assert not isinstance(v, (bool, str, complex)) and v is not None, f.name
        assert math.isfinite(v), f.name


def check_vertices(enum) -> None:
    assert finite(enum.vertices) and finite(enum.rays)


def check_any_finite(x) -> None:
    if isinstance(x, tuple):
        for v in x:
            if isinstance(v, (np.ndarray, float)):
                assert finite(v)
    else:
        assert finite(x)


def check_hypotheses(ls) -> None:
    assert finite(ls.positions)


# ---- the entry points: (callable, baseline kwargs, result check, extra names allowed) --------

def _radial_problem(n, objective, huber_delta, spheres, solver):
    return ro.RadialProblem(n, objective, huber_delta).solve(spheres, solver=solver)


def _from_spheres(spheres, tol):
    return ro.RestrictionPolytope.from_spheres(spheres, tol)


def _from_centers(centers, sigmas, tol):
    return ro.RestrictionPolytope.from_centers(centers, sigmas, tol)


def _meet(spheres, tol):
    if isinstance(spheres, list):
        return ro.meet(*spheres, tol=tol)
    return ro.meet(spheres, tol=tol)


def _contains(x, tol):
    return polytope().contains(x, tol)


def _region_contains(x, tol):
    return ro.Region([-1.0, -1, -1], [1.0, 2, 3]).contains(x, tol)


def _row_name(k):
    return polytope().row_name(k)


def _check_polytope(P) -> None:
    assert finite(P.A) and finite(P.b)


ENTRIES = {
    "project_radii": (ro.project_radii, lambda: dict(spheres=spheres_of(), method="active_set",
                                                      solver=None, check=False, tol=ro.TOLERANCES),
                      "proj"),
    "project_radii_arrays": (ro.project_radii, lambda: dict(centers=CENTERS, radii=RADII, sigmas=SIGMAS,
                                                             method="active_set"), "proj_arrays"),
    "project_radii_paper": (ro.project_radii, lambda: dict(spheres=spheres_of(), method="paper"), "proj"),
    "project_radii_batch": (ro.project_radii_batch, lambda: dict(
        centers=CENTERS[None], radii=RADII[None], sigmas=SIGMAS[None], tol=ro.TOLERANCES), "batch"),
    "common_point_exists": (ro.common_point_exists, lambda: dict(spheres=spheres_of(), tol=1e-9), "bool"),
    "make_spheres": (ro.make_spheres, lambda: dict(centers=CENTERS, radii=RADII, sigmas=SIGMAS), "spheres"),
    "GaussianSphere": (ro.GaussianSphere, lambda: dict(center=CENTERS[1], radius=2.0, sigma=0.1), "sphere"),
    "density": (ro.density, lambda: dict(sphere=spheres_of()[0], x=TRUTH), "density"),
    "radial_density": (ro.radial_density, lambda: dict(radii=RADII, measured=RADII + 0.1, sigmas=SIGMAS),
                       "density"),
    "total_density": (ro.total_density, lambda: dict(spheres=spheres_of(), x=CENTERS), "density"),
    "conformal_sphere": (ro.conformal_sphere, lambda: dict(center=CENTERS[1], radius=2.0), "finite"),
    "conformal_inner": (ro.conformal_inner, lambda: dict(a=np.ones(5), b=np.arange(5.0)), "finite"),
    "meet": (_meet, lambda: dict(spheres=spheres_of()[:3], tol=ro.MEET_TOLERANCES), "meet"),
    "meet2_batch": (ro.meet2_batch, lambda: dict(centers=CENTERS[None, :2], radii_sq=RADII[None, :2] ** 2,
                                                 tol=ro.MEET_TOLERANCES), "bmeet"),
    "meet3_batch": (ro.meet3_batch, lambda: dict(centers=CENTERS[None, :3], radii_sq=RADII[None, :3] ** 2,
                                                 tol=ro.MEET_TOLERANCES), "bmeet"),
    "meet4_batch": (ro.meet4_batch, lambda: dict(centers=CENTERS[None], radii_sq=RADII[None] ** 2,
                                                 tol=ro.MEET_TOLERANCES), "bmeet"),
    "generate_hypotheses": (ro.generate_hypotheses, lambda: dict(
        spheres=spheres_of(), region=ro.Region([-9, -9, -9], [9, 9, 9]), keep_imaginary=True,
        tol=ro.MEET_TOLERANCES), "hyp"),
    "Region": (ro.Region, lambda: dict(lower=[-1.0, -1, -1], upper=[1.0, 2, 3]), "region"),
    "estimate_position": (ro.estimate_position, lambda: dict(
        spheres=spheres_of(), method="ml", region=None, rng=None, options=ro.ESTIMATOR_OPTIONS,
        certify=False), "pos"),
    "srls": (ro.srls, lambda: dict(centers=CENTERS, radii=RADII, sigmas=SIGMAS, rank_tol=1e-9), "finite"),
    "crlb": (ro.crlb, lambda: dict(centers=CENTERS, sigmas=SIGMAS, position=TRUTH, rcond=1e-12), "matrix"),
    "fisher_information": (ro.fisher_information, lambda: dict(centers=CENTERS, sigmas=SIGMAS,
                                                               position=TRUTH), "matrix"),
    "enumerate_vertices": (ro.enumerate_vertices, lambda: dict(polytope=polytope(), method="auto"), "vert"),
    "project_vform": (ro.project_vform, lambda: dict(enumeration=enumeration(), target=RADII[:3],
                                                     sigmas=SIGMAS[:3], tol=1e-14, max_iter=1000), "finite"),
    "certify_projection": (ro.certify_projection, lambda: dict(
        enumeration=enumeration(), polytope=polytope(), target=RADII[:3], sigmas=SIGMAS[:3],
        point=ro.project_radii(spheres_of()[:3]).radii, tol=1e-6), "tuple"),
    "certify_position": (ro.certify_position, lambda: dict(
        spheres=spheres_of(), position=TRUTH, budget_s=0.05, max_nodes=2000, rel_gap=1e-6,
        abs_gap=1e-6, batch=64), "cert"),
    "RadialProblem": (_radial_problem, lambda: dict(n=4, objective="l2", huber_delta=1.0,
                                                    spheres=spheres_of(), solver="CLARABEL"), "proj"),
    "RestrictionPolytope.from_centers": (_from_centers, lambda: dict(centers=CENTERS, sigmas=SIGMAS,
                                                                     tol=ro.TOLERANCES), "poly"),
    "RestrictionPolytope.from_spheres": (_from_spheres, lambda: dict(spheres=spheres_of(),
                                                                     tol=ro.TOLERANCES), "poly"),
    "RestrictionPolytope.contains": (_contains, lambda: dict(x=RADII[:3], tol=1e-9), "boolish"),
    "RestrictionPolytope.row_name": (_row_name, lambda: dict(k=4), "str"),
    "Region.contains": (_region_contains, lambda: dict(x=CENTERS, tol=1e-9), "boolish"),
    "Tolerances": (ro.Tolerances, lambda: dict(coincident=1e-9, feasibility=1e-9, agreement=1e-6), "opts"),
    "EstimatorOptions": (ro.EstimatorOptions, lambda: dict(lm_max_iter=100, rank_tol=1e-9, random_seeds=4,
                                                           distinct_tol=1e-6, max_generation_spheres=6,
                                                           polish_max_nfev=400), "opts"),
    "MeetTolerances": (ro.MeetTolerances, lambda: dict(tangent=1e-10, coincident=1e-12, collinear=1e-9,
                                                       coplanar=1e-9), "opts"),
}


def check_result(kind: str, out, kwargs) -> None:
    spheres = kwargs.get("spheres")
    if kind == "proj":
        check_projection(out, spheres)
    elif kind == "proj_arrays":
        check_projection(out, ro.make_spheres(kwargs["centers"], kwargs["radii"], kwargs["sigmas"]))
    elif kind == "batch":
        assert finite(out.radii) and finite(out.density)
        for b in range(len(out.radii)):
            P = ro.RestrictionPolytope.from_centers(np.asarray(kwargs["centers"], float)[b])
            assert P.contains(out.radii[b], tol=1e-9 * max(1.0, np.abs(P.b).max()))
    elif kind == "bool":
        assert isinstance(out, bool)
    elif kind == "boolish":
        assert isinstance(out, bool) or np.asarray(out).dtype == bool
    elif kind == "str":
        assert isinstance(out, str)
    elif kind == "spheres":
        assert all(isinstance(s, ro.GaussianSphere) for s in out)
    elif kind == "sphere":
        assert finite(out.center) and out.radius >= 0 and out.sigma > 0
    elif kind == "density":
        check_density(out)
    elif kind == "finite":
        check_any_finite(out)
    elif kind == "tuple":
        assert isinstance(out[0], bool)
    elif kind == "meet":
        check_meet(out)
    elif kind == "bmeet":
        check_batch_meet(out)
    elif kind == "hyp":
        check_hypotheses(out)
    elif kind == "region":
        assert np.all(out.lower <= out.upper) and finite(out.lower) and finite(out.upper)
    elif kind == "pos":
        check_position(out, spheres)
    elif kind == "matrix":
        check_matrix(out)
    elif kind == "vert":
        check_vertices(out)
    elif kind == "cert":
        check_certificate(out)
    elif kind == "poly":
        _check_polytope(out)
    elif kind == "opts":
        check_options(out)


def corrupt(data, kwargs: dict) -> tuple[dict, str]:
    name = data.draw(st.sampled_from(sorted(kwargs)), label="argument")
    value = kwargs[name]
    arr = None
    if isinstance(value, np.ndarray) and value.size:
        arr = value
    elif isinstance(value, list) and value and isinstance(value[0], ro.GaussianSphere):
        arr = None
    mode = data.draw(st.sampled_from(["whole", "element"] if arr is not None or isinstance(value, list)
                                     else ["whole"]), label="mode")
    nasty = data.draw(st.sampled_from(NASTY_SCALARS if mode == "element" else NASTY_WHOLE), label="value")
    if mode == "whole":
        kwargs[name] = nasty
    elif arr is not None:
        idx = data.draw(st.integers(0, arr.size - 1), label="index")
        if isinstance(nasty, (int, float)) and not isinstance(nasty, bool) and abs(nasty) < 1e308 + 1:
            new = np.array(arr, dtype=np.float64)
            try:
                new.reshape(-1)[idx] = nasty
            except OverflowError:
                new = new.astype(object)
                new.reshape(-1)[idx] = nasty
        else:
            new = np.array(arr, dtype=object)
            new.reshape(-1)[idx] = nasty
        kwargs[name] = new
    else:  # a list of spheres: replace one entry
        idx = data.draw(st.integers(0, len(value) - 1), label="index")
        new = list(value)
        new[idx] = nasty
        kwargs[name] = new
    return kwargs, name


SPHERE_WORDS = ("spheres", "sigma", "radius", "radii", "center", "centre")


@pytest.mark.parametrize("entry", sorted(ENTRIES))
@given(data=st.data())
def test_fuzz_entry_point(entry, data):
    fn, base, kind = ENTRIES[entry]
    kwargs, name = corrupt(data, base())
    try:
        out = fn(**kwargs)
    except ro.RadialError as exc:
        msg = str(exc)
        words = (name,) + (SPHERE_WORDS if name == "spheres" else ())
        assert any(w in msg for w in words), f"{entry}: message does not name {name!r}: {msg}"
        return
    check_result(kind, out, kwargs)


@pytest.mark.parametrize("entry", sorted(ENTRIES))
def test_baseline_calls_succeed(entry):
    fn, base, kind = ENTRIES[entry]
    kwargs = base()
    check_result(kind, fn(**kwargs), kwargs)


@given(st.lists(st.sampled_from([1e-300, 1e-12, 1e-6, 1.0, 1e6, 1e10, 1e300]), min_size=4, max_size=4),
       st.sampled_from([1.0, 1e6, 1e154, 1e300]))
def test_extreme_sigmas_and_coordinates(sig, shift):
    """Extreme sigmas and far coordinates: a clear error or an honest result, never a crash."""
    for method in ("active_set", "paper"):
        try:
            spheres = spheres_of(CENTERS + shift, RADII, np.array(sig))
            out = ro.project_radii(spheres, method=method)
        except ro.RadialError as exc:
            assert any(w in str(exc) for w in SPHERE_WORDS + ("method",)), str(exc)
            continue
        check_projection(out, spheres)
    try:
        spheres = spheres_of(CENTERS, RADII + shift, np.array(sig))
        est = ro.estimate_position(spheres)
    except ro.RadialError as exc:
        assert any(w in str(exc) for w in SPHERE_WORDS), str(exc)
        return
    check_position(est, spheres)


@st.composite
def nasty_sphere_sets(draw):
    """Valid GaussianSphere lists with extreme but constructible values: tiny/huge sigmas, far,
    coincident, collinear or coplanar centres, zero radii, 0 to 7 spheres."""
    n = draw(st.integers(0, 7))
    layout = draw(st.sampled_from(["random", "collinear", "coplanar", "coincident", "far"]))
    rng = np.random.default_rng(draw(st.integers(0, 2**16)))
    c = rng.uniform(-3, 3, (n, 3))
    if layout == "collinear":
        c[:, 1:] = 0.0
    elif layout == "coplanar":
        c[:, 2] = 0.5
    elif layout == "coincident" and n >= 2:
        c[1] = c[0]
    elif layout == "far":
        c += draw(st.sampled_from([1e6, 1e8, -1e9 + 3.0, 1e9]))
    value = st.sampled_from([0.0, 1e-300, 1e-12, 1e-6, 0.1, 1.0, 7.0, 1e6, 1e9])
    r = np.array([draw(value) for _ in range(n)])
    s = np.array([draw(st.sampled_from([1e-300, 1e-15, 1e-9, 1e-6, 0.1, 1.0, 1e6, 1e12, 1e50]))
                  for _ in range(n)])
    return c, r, s


SPHERE_CALLS = {
    "project_radii": lambda sp: (ro.project_radii(sp), "proj"),
    "project_radii_paper": lambda sp: (ro.project_radii(sp, method="paper"), "proj"),
    "project_radii_vertices": lambda sp: (ro.project_radii(sp[:5], method="vertices"), "proj5"),
    "estimate_position": lambda sp: (ro.estimate_position(sp), "pos"),
    "estimate_position_paper": lambda sp: (ro.estimate_position(sp, method="paper"), "pos"),
    "generate_hypotheses": lambda sp: (ro.generate_hypotheses(sp), "hyp"),
    "common_point_exists": lambda sp: (ro.common_point_exists(sp), "bool"),
    "total_density": lambda sp: (ro.total_density(sp, TRUTH), "density"),
    "from_spheres": lambda sp: (ro.RestrictionPolytope.from_spheres(sp), "poly"),
    "certify_position": lambda sp: (ro.certify_position(sp, TRUTH, budget_s=0.02, max_nodes=500), "cert"),
}


@pytest.mark.parametrize("call", sorted(SPHERE_CALLS))
@settings(max_examples=25)
@given(arrays=nasty_sphere_sets())
def test_fuzz_extreme_sphere_sets(call, arrays):
    try:
        spheres = spheres_of(*arrays)
    except ro.RadialError as exc:  # a sphere beyond the usable range: named
        assert any(w in str(exc) for w in SPHERE_WORDS), str(exc)
        return
    try:
        out, kind = SPHERE_CALLS[call](spheres)
    except ro.RadialError as exc:
        assert any(w in str(exc) for w in SPHERE_WORDS + ("centres", "method", "n = ")), str(exc)
        return
    check_result("proj" if kind == "proj5" else kind, out,
                 {"spheres": spheres[:5] if kind == "proj5" else spheres})


def test_tiny_sigma_error_names_the_index_and_value():
    s = SIGMAS.copy()
    s[2] = 1e-300
    with pytest.raises(ro.RadialError, match=r"sigmas\[2\] = 1e-300"):
        ro.estimate_position(spheres_of(CENTERS, RADII, s))
    with pytest.raises(ro.RadialError, match=r"sigmas\[2\] = 1e-300"):
        ro.make_spheres(CENTERS, RADII, s) and ro.project_radii(ro.make_spheres(CENTERS, RADII, s))


def test_ranges_shifted_by_1e6_never_give_a_success_far_away():
    """Percepts shifted by 1e6 m (the audit's localize case): ranges of ~1e6 m to landmarks a few
    metres apart.  The estimate must not be a success status 1e6 m from the landmarks."""
    far_point = TRUTH + np.array([1e6, 0.0, 0.0])
    r = np.linalg.norm(CENTERS - far_point, axis=1)
    est = ro.estimate_position(spheres_of(CENTERS, r, SIGMAS))
    assert est.status in ro.POSITION_STATUSES
    assert est.status not in ("ok", "ambiguous", "outside_region")


def test_every_status_is_listed():
    import typing

    assert "degenerate" in ro.POSITION_STATUSES and "not_converged" in ro.POSITION_STATUSES
    assert set(ro.STATUSES) == {"optimal", "optimal_inaccurate", "infeasible", "error"}
    assert typing.get_args(ro.PositionStatus) == ro.POSITION_STATUSES


@pytest.mark.parametrize("call", [
    lambda s: ro.project_radii(s), lambda s: ro.project_radii(s, method="paper"),
    lambda s: ro.common_point_exists(s), lambda s: ro.total_density(s, np.zeros(3)),
    lambda s: ro.generate_hypotheses(s), lambda s: ro.estimate_position(s),
    lambda s: ro.estimate_position(s, method="srls"), lambda s: ro.certify_position(s, np.zeros(3)),
])
def test_zero_d_array_as_spheres_is_a_named_error(call):
    """Audit: a numpy 0-d array passed as ``spheres`` escaped as TypeError (iteration over a 0-d array)."""
    with pytest.raises(ro.RadialError, match="spheres"):
        call(np.array(2.0))


@pytest.mark.parametrize("call", [
    lambda: ro.RadialProblem(4).fix_radius(1, 10**400),
    lambda: ro.RadialProblem(4).bound_radii(lo=10**400),
    lambda: ro.RadialProblem(4).bound_radii(hi=10**400),
])
def test_radial_problem_huge_int_is_a_package_error(call):
    """Audit: an int of 10**400 escaped from float() as OverflowError."""
    with pytest.raises(ro.RadialError, match="value|lo|hi"):
        call()


def test_add_constraint_callable_that_raises_is_a_named_error():
    """Audit: a constraint callable raising ZeroDivisionError escaped from add_constraint."""
    with pytest.raises(ro.RadialError, match="fn raised ZeroDivisionError"):
        ro.RadialProblem(3).add_constraint(lambda x: 1 / 0)


@pytest.mark.parametrize(("call", "like"), [
    (lambda: ro.make_spheres(np.zeros((0, 3)), RADII, SIGMAS), "centers"),
    (lambda: ro.srls(np.zeros((0, 3)), RADII, SIGMAS), "centers"),
    (lambda: ro.radial_density([], RADII, SIGMAS), "radii"),
])
def test_length_mismatch_names_the_reference_argument(call, like):
    """Audit: an empty centers gave "radii must have shape (0,)", naming only the other argument."""
    with pytest.raises(ro.RadialError, match=f"like {like}"):
        call()
