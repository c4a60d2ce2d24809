"""Fuzz tests of worldgraph's association, pose and localisation entry points.

For each public entry point hypothesis draws nasty values (NaN, inf, +-1e308, 1e-300, negative,
zero, huge ints, bool, None, str, complex, wrong shapes, empty arrays, non-symmetric or indefinite
matrices, non-rigid transforms) and the test asserts that the call either raises
:class:`worldgraph.WorldGraphError` whose message names the argument, or returns a result that
is finite and satisfies its status's constraints.  Any other exception fails the test.

A small world (``WorldModel.from_arrays``, 20 objects of 4 types) keeps it fast.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import worldgraph as wg
from perception import Percept, PerceptionError
from tests.worlds import four_type_world
from worldgraph.association.cliques import maximum_cliques
from worldgraph.association.filters import consistency_graph
from worldgraph.association.hypotheses import AssociationHypothesis, is_ambiguous, same_pose
from worldgraph.pose import (
    percept_frame,
    pose_from_frames,
    pose_information,
    refine_pose,
    rotation_angle,
    transformation,
    weighted_kabsch,
    weighted_kabsch_batch,
    weighted_rotation,
)
from worldgraph.pose import validation as val

SUCCESS = ("ok", "weak", "ambiguous")

NASTY_SCALARS = [math.nan, math.inf, -math.inf, 1e308, -1e308, 1e-300, -1.0, 0.0, 0, -3, 10**30, True,
                 False, None, "3", 1 + 2j, 2.5, 1e6, 7]
nasty_scalar = st.sampled_from(NASTY_SCALARS)
nasty_float = st.one_of(st.floats(allow_nan=True, allow_infinity=True), nasty_scalar)


WORLD = four_type_world()
POSE = transformation(Rotation.from_euler("z", 0.3).as_matrix(), np.array([2.0, 3.0, 0.5]))


def _clean_percepts(idx=range(8), sigma=0.02, seed=1, shift=None) -> list[Percept]:
    rng = np.random.default_rng(seed)
    R, t = POSE[:3, :3], POSE[:3, 3]
    out = []
    for i in idx:
        # the noise draw is capped at 1 m so that an extreme sigma (1e300) still gives positions
        # inside perception's 1e9 m bound: the sigma itself is what the tests exercise
        x = R.T @ (WORLD.positions[i] - t) + min(sigma, 1.0) * rng.standard_normal(3)
        if shift is not None:
            x = x + shift
        out.append(Percept(WORLD.objects[i].type, x, sigma))
    return out


CLEAN = _clean_percepts()


def _raises_named(exc: Exception, *names: str) -> None:
    assert isinstance(exc, wg.WorldGraphError), repr(exc)
    assert any(n in str(exc) for n in names), f"message names none of {names}: {exc}"


def _call(fn, names, *args, **kwargs):
    """The result, or None after a WorldGraphError naming one of ``names``; anything else fails."""
    try:
        return fn(*args, **kwargs)
    except wg.WorldGraphError as exc:
        _raises_named(exc, *names)
        return None


def _check_result(res: wg.LocalizationResult) -> None:
    assert res.status in wg.LOCALIZE_STATUSES
    if res.status in SUCCESS:
        T = res.transformation
        assert np.all(np.isfinite(T)) and np.all(np.isfinite(res.pose_covariance))
        assert np.all(np.isfinite(res.covariance)) and np.all(np.isfinite(res.position))
        assert np.allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=1e-6)
        assert np.linalg.det(T[:3, :3]) > 0
        assert np.allclose(T[3], [0, 0, 0, 1])


@st.composite
def percept_lists(draw):
    """Percepts of the world's types, some with nasty sigmas, positions, covariances."""
    k = draw(st.integers(0, 9))
    out = []
    for i in range(k):
        base = CLEAN[i % len(CLEAN)]
        sigma = draw(st.sampled_from([base.sigma, 1e-300, 1e-13, 1e-12, 1e-3, 1.0, 1e9, 1e10, 1e300]))
        pos = base.position * draw(st.sampled_from([1.0, 1.0, -1.0, 1e6, 1e12, 0.0]))
        cov = draw(st.sampled_from([None, None, "needle", "tiny", "huge"]))
        C = None
        if cov == "needle":
            C = np.diag([100.0**2, 1e-4, 1e-4])
        elif cov == "tiny":
            C = 1e-290 * np.eye(3)
        elif cov == "huge":
            C = 1e290 * np.eye(3)
        typ = draw(st.sampled_from([base.type, base.type, "unknown"]))
        try:  # with a covariance, the sigma it gives (a drawn one would contradict it: refused)
            out.append(Percept(typ, pos, sigma if C is None else None, C))
        except PerceptionError:
            assume(False)
    return out


# ------------------------------------------------------------------------------------------------
# localize
# ------------------------------------------------------------------------------------------------
@settings(max_examples=30)
@given(percepts=percept_lists(), method=st.sampled_from(wg.LOCALIZE_METHODS))
def test_localize_on_nasty_percepts(percepts, method) -> None:
    res = _call(wg.localize, ("percepts", "world"), WORLD, percepts, method)
    if res is not None:
        _check_result(res)


@settings(max_examples=40)
@given(arg=st.sampled_from(["method", "tol", "region", "rng", "max_position_3sigma",
                            "max_rotation_3sigma", "solver", "check", "certify", "percepts", "world"]),
       value=st.one_of(nasty_scalar, st.sampled_from([
           (np.zeros(3), np.ones(3)), (np.ones(3), np.zeros(3)), (np.zeros(2),), [np.zeros(3), "x"],
           np.zeros((2, 3)), [], "seed", [1, 2, 3], {"a": 1}, np.random.default_rng(0)])))
def test_localize_arguments(arg, value) -> None:
    kwargs = {}
    args = [WORLD, CLEAN]
    if arg == "world":
        args[0] = value
    elif arg == "percepts":
        args[1] = value
    elif arg == "method":
        args.append(value)
    else:
        kwargs[arg] = value
    res = _call(wg.localize, (arg,), *args, **kwargs)
    if res is not None:
        _check_result(res)


def test_localize_region_pair_and_generator_are_accepted() -> None:
    lo, hi = np.zeros(3), np.array([6.0, 6.0, 2.0])
    res = wg.localize(WORLD, CLEAN, region=(lo, hi), rng=np.random.default_rng(1))
    assert res.status == "ok"
    assert np.linalg.norm(res.position - POSE[:3, 3]) < 0.1
    far = wg.localize(WORLD, CLEAN, region=(lo + 100, hi + 100))
    assert far.status == "outside_region"


@pytest.mark.parametrize("method", wg.LOCALIZE_METHODS)
def test_percepts_a_million_metres_off_are_no_success(method) -> None:
    """Percepts shifted by 1e6 m must not give an ok/weak/ambiguous pose 1e6 m away."""
    shifted = _clean_percepts(shift=np.array([1e6, 0.0, 0.0]))
    res = _call(wg.localize, ("percepts",), WORLD, shifted, method)
    if res is not None:
        _check_result(res)
        if res.status in SUCCESS:
            assert np.linalg.norm(res.position - POSE[:3, 3]) < 1e3


@pytest.mark.parametrize("sigma", [1e-300, 1e300])
def test_extreme_sigma_names_the_percept(sigma) -> None:
    with pytest.raises(wg.WorldGraphError, match=r"percepts\[0\].*sigma"):
        wg.localize(WORLD, _clean_percepts(sigma=sigma))


# ------------------------------------------------------------------------------------------------
# AssociationTolerances, associate, filters, discriminator
# ------------------------------------------------------------------------------------------------
TOL_FIELDS = [f for f in wg.AssociationTolerances.__dataclass_fields__]


@given(field=st.sampled_from(TOL_FIELDS), value=nasty_float)
def test_tolerances_fields(field, value) -> None:
    tol = _call(wg.AssociationTolerances, (f"AssociationTolerances.{field}", field), **{field: value})
    if tol is None:
        return
    for name in TOL_FIELDS:
        v = getattr(tol, name)
        if v is not None:
            assert isinstance(v, bool | int | float) and not isinstance(v, complex)
            assert math.isfinite(float(v))
    assert tol.kappa_max <= math.pi
    res = _call(wg.localize, ("percepts",), WORLD, CLEAN, tol=tol)
    if res is not None:
        _check_result(res)


def test_degrees_for_kappa_max_suggest_radians() -> None:
    with pytest.raises(wg.WorldGraphError, match="np.radians"):
        wg.AssociationTolerances(kappa_max=20.0)


@settings(max_examples=30)
@given(percepts=percept_lists(), method=st.sampled_from(["clique", "paper", "other", None, 3]),
       max_hypotheses=st.one_of(st.none(), nasty_scalar))
def test_associate(percepts, method, max_hypotheses) -> None:
    hyps = _call(wg.associate, ("percepts", "method", "max_hypotheses", "association needs", "world"),
                 WORLD, percepts, method=method, max_hypotheses=max_hypotheses)
    if hyps is None:
        return
    for h in hyps:
        assert np.all(np.isfinite(h.world_from_ego)) and math.isfinite(h.cost)
        assert np.allclose(h.world_from_ego[:3, :3].T @ h.world_from_ego[:3, :3], np.eye(3), atol=1e-6)


@settings(max_examples=30)
@given(percepts=percept_lists(), tol=st.sampled_from([wg.ASSOCIATION_TOLERANCES, None, "tol", 3]))
def test_filters(percepts, tol) -> None:
    prox = _call(wg.proximity_filter, ("percepts", "tol", "world"), WORLD, percepts, tol)
    if prox is None:
        return
    filt = _call(wg.orientation_filter, ("percepts", "tol"), WORLD, percepts, prox, tol)
    if filt is not None:
        assert len(filt["candidates"]) == len(percepts)
    _call(consistency_graph, ("percepts", "tol", "min_size"), WORLD, percepts, tol)


@given(proximity=st.sampled_from([None, {}, {"objects": [], "adjacency": {}}, "x", 3,
                                  {"objects": [np.array([0])] * 8, "adjacency": {(0, 1): np.ones((2, 2))}}]))
def test_orientation_filter_rejects_a_bad_proximity(proximity) -> None:
    _call(wg.orientation_filter, ("proximity",), WORLD, CLEAN, proximity)


@st.composite
def hypothesis_lists(draw):
    n = draw(st.integers(0, 3))
    out = []
    for _ in range(n):
        kind = draw(st.sampled_from(["good", "nan", "scaled", "reflect", "shape", "other"]))
        T = POSE.copy()
        if kind == "nan":
            T[0, 3] = np.nan
        elif kind == "scaled":
            T[:3, :3] *= 2.0
        elif kind == "reflect":
            T[:3, 2] *= -1.0
        elif kind == "shape":
            T = np.eye(3)
        elif kind == "other":
            out.append("not a hypothesis")
            continue
        out.append(AssociationHypothesis(pairs=((0, 0),), cost=1.0, size=1, world_from_ego=T))
    return out


@given(hyps=st.one_of(hypothesis_lists(), st.sampled_from([None, 3, "ab"])),
       max_range=st.one_of(st.none(), nasty_scalar))
def test_discriminator(hyps, max_range) -> None:
    out = _call(wg.discriminator, ("hypotheses", "max_range", "discriminator needs"), WORLD, hyps,
                max_range=max_range)
    if out is not None:
        assert isinstance(out, int) and 0 <= out < len(WORLD)
    _call(is_ambiguous, ("hypotheses",), hyps)


@given(a=st.sampled_from([POSE, np.eye(4), np.eye(3), np.full((4, 4), np.nan), 2 * np.eye(4), None]),
       tol=st.sampled_from([wg.ASSOCIATION_TOLERANCES, None]))
def test_same_pose(a, tol) -> None:
    out = _call(same_pose, ("a", "tol"), a, POSE, tol)
    assert out is None or isinstance(out, bool)


@given(sizes=st.one_of(st.lists(nasty_scalar, max_size=4), st.lists(st.integers(0, 4), max_size=4)),
       min_size=nasty_scalar)
def test_maximum_cliques(sizes, min_size) -> None:
    out = _call(maximum_cliques, ("sizes", "min_size", "adjacency"), sizes, {}, min_size=min_size)
    if out is not None:
        assert out.maximum >= 0


# ------------------------------------------------------------------------------------------------
# pose functions
# ------------------------------------------------------------------------------------------------
def _nasty_array(shape):
    good = np.random.default_rng(5).uniform(-3, 3, shape)
    return st.sampled_from([
        good, good * 1e300, good * 1e-300, np.full(shape, np.nan), np.full(shape, np.inf),
        good.astype(complex) * 1j, np.zeros(shape), np.zeros((0, 3)), np.zeros((2, 2)), None, "abc",
        [[1, 2, "x"]], good.tolist(), np.ones(shape, dtype=bool), good[..., :2]])


@given(a=_nasty_array((3,)), b=_nasty_array((3,)))
def test_percept_frame(a, b) -> None:
    out = _call(percept_frame, ("a", "b", "c", "collinear"), a, b, np.array([0.3, 2.0, -1.0]))
    if out is not None:
        assert np.all(np.isfinite(out))
        assert np.allclose(out[:3, :3].T @ out[:3, :3], np.eye(3), atol=1e-9)
        frame = out
        res = _call(pose_from_frames, ("model_frame", "percept_frame_"), frame, frame)
        assert res is not None and np.allclose(res, np.eye(4), atol=1e-9)


@given(m=st.sampled_from([np.eye(4), 2 * np.eye(4), np.diag([1, 1, -1, 1.0]), np.full((4, 4), np.nan),
                          np.eye(3), None, "x", np.eye(4) + 1e-3, np.eye(4).astype(complex)]))
def test_pose_from_frames_and_rotation_angle(m) -> None:
    out = _call(pose_from_frames, ("model_frame", "percept_frame_"), m, np.eye(4))
    if out is not None:
        assert np.all(np.isfinite(out))
    ang = _call(rotation_angle, ("rotation_a",), m, np.eye(4))
    assert ang is None or (math.isfinite(ang) and 0 <= ang <= math.pi)


@given(x=_nasty_array((5, 3)), w=st.one_of(_nasty_array((5,)), st.sampled_from([
    np.array([1.0, -1, 1, 1, 1]), np.zeros(5), np.full(5, 1e300), np.ones(4)])))
def test_weighted_kabsch(x, w) -> None:
    y = np.random.default_rng(6).uniform(-3, 3, (5, 3))
    for fn in (weighted_kabsch, weighted_rotation):
        out = _call(fn, ("ego_points", "ego_vectors", "world_points", "world_vectors", "weights"), x, y, w)
        if out is not None:
            R = out[0] if fn is weighted_kabsch else out
            assert np.all(np.isfinite(R)) and np.allclose(R.T @ R, np.eye(3), atol=1e-9)
    xb = np.asarray(x)[None] if isinstance(x, np.ndarray) else x
    wb = np.asarray(w)[None] if isinstance(w, np.ndarray) else w
    out = _call(weighted_kabsch_batch, ("ego_points", "world_points", "weights"), xb, y[None], wb)
    if out is not None:
        assert np.all(np.isfinite(out[0])) and np.all(np.isfinite(out[1]))


COV_CASES = {
    "good": np.broadcast_to(np.diag([0.04, 0.01, 0.01]), (5, 3, 3)).copy(),
    "needle": np.broadcast_to(np.diag([1e4, 1e-4, 1e-4]), (5, 3, 3)).copy(),
    "indefinite": np.broadcast_to(np.diag([1.0, -1.0, 1.0]), (5, 3, 3)).copy(),
    "asym": np.broadcast_to(np.array([[1.0, 0.5, 0], [0, 1, 0], [0, 0, 1]]), (5, 3, 3)).copy(),
    "zero": np.zeros((5, 3, 3)),
    "tiny": np.broadcast_to(1e-300 * np.eye(3), (5, 3, 3)).copy(),
    "huge": np.broadcast_to(1e300 * np.eye(3), (5, 3, 3)).copy(),
    "nan": np.full((5, 3, 3), np.nan),
    "shape": np.eye(3),
    "complex": np.broadcast_to(np.eye(3), (5, 3, 3)).astype(complex),
}


@settings(max_examples=40)
@given(x=_nasty_array((5, 3)), cov=st.sampled_from(sorted(COV_CASES)),
       start=st.sampled_from([POSE, np.eye(4), 2 * np.eye(4), np.full((4, 4), np.nan), np.eye(3)]),
       max_iter=st.sampled_from([200, 1, 0, -1, 2.5, None, True, "3", 10**30]))
def test_refine_pose_and_information(x, cov, start, max_iter) -> None:
    y = np.random.default_rng(6).uniform(-3, 3, (5, 3))
    C = COV_CASES[cov]
    out = _call(refine_pose, ("ego_points", "world_points", "covariances", "world_from_ego", "max_iter",
                              "converge", "pose"), x, y, C, start, max_iter=max_iter)
    if out is not None:
        T, info = out
        assert np.all(np.isfinite(T)) and np.all(np.isfinite(info))
        assert np.allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=1e-9)
    info = _call(pose_information, ("world_from_ego", "ego_points", "covariances"), start, x, C)
    if info is not None:
        assert np.all(np.isfinite(info))


# ------------------------------------------------------------------------------------------------
# validation helpers
# ------------------------------------------------------------------------------------------------
@settings(max_examples=40)
@given(x=_nasty_array((5, 3)), cov=st.sampled_from(sorted(COV_CASES)),
       pose=st.sampled_from([POSE, 2 * np.eye(4), np.full((4, 4), np.nan), None]),
       pcov=st.sampled_from([np.eye(6) * 1e-4, np.full((6, 6), np.inf), np.eye(3), None, "x", -np.eye(6)]),
       alpha=st.sampled_from([1e-3, 0.0, -1.0, 2.0, math.nan, None]))
def test_validation_helpers(x, cov, pose, pcov, alpha) -> None:
    y = np.random.default_rng(6).uniform(-3, 3, (5, 3))
    C = COV_CASES[cov]
    names = ("world_from_ego", "ego", "covs", "covariances", "world_points", "pose_covariance", "alpha",
             "weights", "position_covariance", "singular")
    d2 = _call(val.placed_mahalanobis, names, pose, x, C, y, pcov)
    if d2 is not None:
        assert d2.shape == (5,) and not np.any(np.isnan(d2))
    cost = _call(val.pose_cost, names, pose, x, C, y)
    assert cost is None or (math.isfinite(cost) and cost >= 0)
    out = _call(val.self_check, names, pose, x, C, y, pcov, alpha=alpha)
    if out is not None:
        assert isinstance(out[0], bool)
    out = _call(val.rotation_only_covariance, names, pose, x, C, np.ones(5), np.eye(3) * 1e-4)
    if out is not None:
        assert out.shape == (6, 6)
    _call(val.ros_pose_covariance, ("information", "singular"), pcov)
    _call(val.percept_covariances, ("percepts",), x)


def test_percept_covariances_of_percepts() -> None:
    covs = val.percept_covariances(CLEAN)
    assert np.allclose(covs, 0.02**2 * np.eye(3))


@given(candidates=st.sampled_from([[np.array([0, 1])], [np.array([-1])], [np.array([99])], None, "ab",
                                   [np.array(["x"])], [[0, [1, 2]]], [np.array([0.5])]]),
       links=st.sampled_from([{}, {(0, 1): np.array([[0, 1]])}, {(0, 1): np.array([[0, 100]])},
                              {(0, 1): np.array([1, 2, 3])}, None, {(0, 1): "x"}]))
def test_filtered_graph_view(candidates, links) -> None:
    from worldgraph.association.filters import filtered_graph_view

    g = _call(filtered_graph_view, ("candidates", "links"), WORLD, candidates, links)
    if g is not None:
        assert all(0 <= n < len(WORLD) for n in g.nodes)


@given(min_size=nasty_scalar)
def test_consistency_graph_min_size(min_size) -> None:
    g = _call(consistency_graph, ("min_size",), WORLD, CLEAN, min_size=min_size)
    if g is not None:
        assert all(d["type"] == CLEAN[d["percept"]].type for _, d in g.nodes(data=True))


@given(pairs=st.sampled_from([[(0, 0), (1, 1), (2, 2)], [(0, 99)], [(-1, 0)], [(0.5, 1)], [(True, 1)], None,
                              "ab", [(0,)], [[0, 1, 2]], []]))
def test_match_spheres_and_default_region(pairs) -> None:
    from worldgraph.localization import default_region, match_spheres

    out = _call(match_spheres, ("pairs",), WORLD, CLEAN, pairs)
    if out is not None:
        p_i, o_i, spheres = out
        assert len(p_i) == len(o_i) == len(spheres)
    region = default_region(WORLD, CLEAN)
    assert np.all(np.isfinite(region.lower)) and np.all(region.lower <= region.upper)
    _call(default_region, ("percepts",), WORLD, pairs)


@given(pcov=st.sampled_from([np.eye(6) * 1e-4, -np.eye(6), np.diag([1e-4] * 5 + [0.0]),
                             np.full((6, 6), np.inf), np.eye(3), None, "x", np.triu(np.ones((6, 6)))]),
       types=st.sampled_from([["t0"] * 5, ["zz"], None, "t0", [3], []]))
def test_covariance_helpers_and_nearest(pcov, types) -> None:
    x = np.random.default_rng(7).uniform(-3, 3, (5, 3))
    C = COV_CASES["good"]
    for fn in (val.curved_pose_covariance, val.laplace_inflate, val.calibrated_pose_covariance):
        args = (POSE, x, C, pcov) if fn is val.curved_pose_covariance else (POSE, x, C, x, pcov)
        out = _call(fn, ("pose_covariance",), *args)
        if out is not None and np.all(np.isfinite(np.asarray(pcov, dtype=float))):
            assert out.shape == (6, 6) and np.all(np.isfinite(out))
    near = _call(val.NearestObjects, ("types", "world"), WORLD, types)
    if near is not None:
        d2, obj, _ = near.query(POSE, x[: len(types)], C[: len(types)], None)
        assert np.all(obj >= 0)


_EGO5 = np.random.default_rng(8).uniform(-3, 3, (5, 3))
_COV5 = np.broadcast_to(0.01 * np.eye(3), (5, 3, 3)).copy()


@pytest.mark.parametrize(("call", "name"), [
    # world_points=None escaped as TypeError (None meant "not given" inside the shared check)
    (lambda: val.pose_cost(POSE, _EGO5, _COV5, None), "world_points"),
    (lambda: val.placed_mahalanobis(POSE, _EGO5, _COV5, None), "world_points"),
    (lambda: val.self_check(POSE, _EGO5, _COV5, None, np.eye(6) * 1e-4), "world_points"),
    # a non-iterable percepts escaped as TypeError
    (lambda: val.percept_covariances(2.5), "percepts"),
    (lambda: val.percept_covariances(np.array(2.0)), "percepts"),
    (lambda: val.percept_covariances(None), "percepts"),
    # the covariance argument is called covs here; messages said "covariances"
    (lambda: val.pose_cost(POSE, _EGO5, math.nan, _EGO5), "covs"),
    (lambda: val.rotation_only_covariance(POSE, _EGO5, np.zeros((2, 2)), np.ones(5), np.eye(3)), "covs"),
    (lambda: val.self_check(POSE, _EGO5, -_COV5, _EGO5, np.eye(6) * 1e-4), "covs[0]"),
])
def test_validation_audit_cases_are_named_errors(call, name) -> None:
    """Cases found by the independent audit: each must be a WorldGraphError naming the argument."""
    with pytest.raises(wg.WorldGraphError) as info:
        call()
    assert name in str(info.value), str(info.value)


@pytest.mark.parametrize(("call", "name"), [
    (lambda: val.NearestObjects(WORLD, 2.5), "types"),
    (lambda: val.NearestObjects(WORLD, np.array(2.0)), "types"),
    (lambda: val.shared_view_covariance(POSE, _EGO5, _COV5, 2.5), "shared"),
    (lambda: val.shared_view_covariance(POSE, _EGO5, _COV5, np.array(2.0)), "shared"),
])
def test_validation_non_sequence_arguments_are_named(call, name) -> None:
    """Audit: non-iterable ``types``/``shared`` escaped as TypeError."""
    with pytest.raises(wg.WorldGraphError, match=name):
        call()


def test_percept_covariances_overflowing_sigma_is_named() -> None:
    """Audit: a percept sigma of 1e300 m escaped as OverflowError from sigma**2."""
    with pytest.raises(wg.WorldGraphError, match=r"percepts\[1\]\.sigma"):
        val.percept_covariances([CLEAN[0], Percept(CLEAN[1].type, CLEAN[1].position, 1e300)])


@pytest.mark.parametrize("call", [
    lambda e: wg.weighted_kabsch(e, _EGO5, np.ones(5)),
    lambda e: refine_pose(e, _EGO5, _COV5, POSE),
    lambda e: pose_information(POSE, e, _COV5),
    lambda e: val.pose_cost(POSE, e, _COV5, _EGO5),
    lambda e: val.curved_pose_covariance(POSE, e, _COV5, np.eye(6) * 1e-4),
])
def test_length_mismatch_names_the_reference_argument(call) -> None:
    """Audit: an empty ego array gave "world_points must have shape (0, 3)", naming only the other
    argument; the message now names the argument the length comes from as well."""
    with pytest.raises(wg.WorldGraphError, match=r"like ego(_points)?\b"):
        call(np.zeros((0, 3)))


@pytest.fixture(scope="module")
def kitchen_world() -> wg.WorldModel:
    return wg.scenes.kitchen(seed=0)


KITCHEN_TYPES = sorted(wg.scenes.kitchen(seed=0).type_names)


@settings(max_examples=25)
@given(types=st.lists(st.sampled_from(KITCHEN_TYPES), min_size=3, max_size=6),
       point=st.tuples(*[st.floats(-3.0, 3.0)] * 3), sigma=st.floats(0.005, 0.2))
@example(types=["appliance", "appliance", "book"], point=(1.0, 0.5, 0.2), sigma=0.05)
def test_percepts_at_one_point_give_a_status_in_every_method(kitchen_world, types, point, sigma) -> None:
    """Percepts that all sit at one point (any types of the world, any sigma) fix no pose: every
    method answers with a failure status, never an exception (the paper's eq. 5 raised
    percept_frame's PoseError when its association found a match for such percepts)."""
    percepts = [Percept(t, np.array(point), sigma) for t in types]
    for method in wg.LOCALIZE_METHODS:
        res = wg.localize(kitchen_world, percepts, method=method)
        assert res.status not in ("ok", "weak"), (method, res.status)
        _check_result(res)


def test_the_paper_method_names_the_percepts_that_span_no_plane(kitchen_world) -> None:
    # two appliances and a book at one point: the paper's filters match them (objects a few
    # centimetres apart), its eq. 5 needs a triangle of percepts
    percepts = [Percept(t, np.array([1.0, 0.5, 0.2]), 0.05) for t in ("appliance", "appliance", "book")]
    res = wg.localize(kitchen_world, percepts, method="paper")
    assert res.status == "degenerate"
    assert "eq. 5" in res.message and "percepts [0, 1, 2]" in res.message
