"""LocalizeSettings: one checked object that every entry point builds once and hands down."""

from __future__ import annotations

import dataclasses
import math
import pickle

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import radialopt as ro
import worldgraph as wg
from perception import Percept
from worldgraph.errors import WorldGraphError
from worldgraph.localization import pipeline
from worldgraph.localization.result import poseless_result
from worldgraph.localization.settings import settings_of
from worldgraph.pose.gravity import FREE_SEARCH

LANDMARKS = np.array([[3.0, -1.2, 0.9], [3.4, 0.3, 1.6], [4.1, 1.5, 0.4], [5.2, -0.4, 2.1],
                      [5.8, 1.1, 1.0], [4.6, -1.9, 1.3], [3.7, 2.2, 2.0]])
TYPES = ["door", "handle", "drawer", "knob", "door", "handle", "drawer"]


def _pose(yaw_deg: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("z", yaw_deg, degrees=True).as_matrix()
    T[:3, 3] = [0.2, -0.1, 1.5]
    return T


def _percepts(pose: np.ndarray, rng: np.random.Generator, depth_factor: float = 400.0) -> list[Percept]:
    ego = (LANDMARKS - pose[:3, 3]) @ pose[:3, :3]
    out = []
    for t, x in zip(TYPES, ego, strict=True):
        s = float(x @ x) / depth_factor
        out.append(Percept(t, x + rng.normal(0.0, s, 3), s))
    return out


@pytest.fixture(scope="module")
def world() -> wg.WorldModel:
    return wg.WorldModel.from_arrays(TYPES, LANDMARKS, max_link_length=8.0)


def _same(a: wg.LocalizationResult, b: wg.LocalizationResult) -> None:
    assert a.status == b.status and a.message == b.message
    assert a.correspondences == b.correspondences
    np.testing.assert_array_equal(a.transformation, b.transformation)
    np.testing.assert_array_equal(a.pose_covariance, b.pose_covariance)


def test_the_settings_check_their_fields_with_the_keywords_messages() -> None:
    cases = [
        (dict(method="lsq"), r"method must be one of \('ml', 'spheres', 'paper', 'srls', 'gradient'\), "
                             r"got 'lsq'"),
        (dict(solver=3), r"solver must be 'active_set' or a cvxpy solver name, got 3"),
        (dict(solver="NOPE"), r"solver 'NOPE' is neither 'active_set' nor an installed cvxpy solver"),
        (dict(check=1), r"check must be a bool, got 1"),
        (dict(certify="yes"), r"certify must be a bool, got 'yes'"),
        (dict(max_position_3sigma=-1.0), r"max_position_3sigma"),
        (dict(max_rotation_3sigma=5.0), r"max_rotation_3sigma = 5\.0 is an angle in radians and must be "
                                        r"<= pi; did you mean degrees\? np\.radians\(5\) = 0\.08727"),
        (dict(gravity=(0.0, 0.0, -1.0)), r"gravity = \[0\.0, 0\.0, -1\.0\] points 180 deg from the ego "
                                         r"\+z axis"),
        (dict(gravity=True), r"gravity must be 'auto'.*got True"),
        (dict(up_sigma=0.0), r"up_sigma = 0\.0 must be > 0"),
        (dict(region=(np.zeros(3), np.zeros(2))), r"region\[1\]"),
        (dict(region="room"), r"region must be None, a radialopt\.Region or a \(lower, upper\) pair"),
        (dict(tol=3), r"tol"),
    ]
    for kwargs, pattern in cases:
        with pytest.raises(WorldGraphError, match=pattern):
            wg.LocalizeSettings(**kwargs)


def test_the_settings_normalise_what_they_are_given() -> None:
    s = wg.LocalizeSettings(region=([-1.0, -1.0, 0.0], [1.0, 1.0, 2.0]), gravity=np.array([0.0, 0.1, 1.0]),
                            solver="active_set", check=np.bool_(True), tol=None)
    assert isinstance(s.region, ro.Region)
    np.testing.assert_array_equal(s.region.lower, [-1.0, -1.0, 0.0])
    assert s.gravity == (0.0, 0.1, 1.0) and isinstance(s.gravity, tuple)
    np.testing.assert_allclose(s.plan.up, np.array([0.0, 0.1, 1.0]) / math.hypot(0.1, 1.0))
    assert s.plan.level is not None and not s.plan.fallback  # an explicit up vector: no fall-back
    assert s.check is True and type(s.check) is bool
    assert s.tol is wg.ASSOCIATION_TOLERANCES
    # the default tilt prior: a third of the tilt allowance
    assert s.tilt_sd == pytest.approx(wg.ASSOCIATION_TOLERANCES.tilt_allowance / 3.0)
    assert s.tilt_prior is not None and s.tilt_prior.sd == pytest.approx(s.tilt_sd)
    assert wg.LocalizeSettings(up_sigma=math.inf).tilt_prior is None
    free = s.free_search()
    assert free.gravity is None and free.plan is FREE_SEARCH and free.tilt_prior is None
    assert dataclasses.replace(free, method="paper").region is free.region
    # auto: about +z, and the free search may answer instead
    auto = wg.LocalizeSettings()
    assert auto.plan.fallback and np.array_equal(auto.plan.up, [0.0, 0.0, 1.0])
    # a worker gets them by pickle
    back = pickle.loads(pickle.dumps(s))
    assert back.gravity == s.gravity and np.array_equal(back.plan.up, s.plan.up)


def test_keywords_other_than_their_defaults_replace_the_settings_fields() -> None:
    base = wg.LocalizeSettings(method="spheres", max_position_3sigma=0.1, gravity=None)
    assert settings_of(base, method="ml", tol=None, gravity="auto") is base  # all defaults: the object
    mixed = settings_of(base, method="paper", up_sigma=0.02)
    assert (mixed.method, mixed.max_position_3sigma, mixed.gravity, mixed.up_sigma) == (
        "paper", 0.1, None, 0.02)
    assert settings_of(None, gravity=None).plan is FREE_SEARCH  # None is not gravity's default
    with pytest.raises(WorldGraphError, match=r"settings must be None or a worldgraph\.LocalizeSettings, "
                                              r"got \{'method': 'ml'\}"):
        settings_of({"method": "ml"})
    with pytest.raises(WorldGraphError, match=r"max_rotation_3sigma = 7\.0"):
        settings_of(base, max_rotation_3sigma=7.0)


def test_localize_with_settings_answers_as_with_keywords(world) -> None:
    rng = np.random.default_rng(3)
    percepts = _percepts(_pose(20.0), rng)
    keywords = dict(method="spheres", max_position_3sigma=0.3, max_rotation_3sigma=0.1, up_sigma=0.05)
    by_keywords = wg.localize(world, percepts, **keywords)
    settings = wg.LocalizeSettings(**keywords)
    assert by_keywords.status in ("ok", "weak")
    _same(wg.localize(world, percepts, settings=settings), by_keywords)
    # a keyword other than its default replaces one field for this call only
    _same(wg.localize(world, percepts, settings=settings, method="paper"),
          wg.localize(world, percepts, **{**keywords, "method": "paper"}))
    # one left at its default takes the settings' value (replace sets a field back to the default)
    _same(wg.localize(world, percepts, settings=settings, method="ml"), by_keywords)
    _same(wg.localize(world, percepts, settings=dataclasses.replace(settings, method="ml")),
          wg.localize(world, percepts, **{**keywords, "method": "ml"}))
    tight = wg.localize(world, percepts, settings=dataclasses.replace(settings, max_position_3sigma=1e-4))
    assert tight.status == "weak" and "tolerance 0.0001" in tight.message


def test_every_entry_point_hands_the_settings_down(world) -> None:
    """A setting that localize_tiled and active_localize have no keyword for reaches every tile
    and every look's localisation."""
    rng = np.random.default_rng(5)
    percepts = _percepts(_pose(-15.0), rng)
    tight = wg.LocalizeSettings(max_position_3sigma=1e-4)
    alone = wg.localize(world, percepts, settings=tight)
    assert alone.status == "weak"
    tiles = wg.tiles.split(world, np.zeros(len(world), dtype=int))
    tiled = wg.localize_tiled(tiles, percepts, workers=1, settings=tight)
    assert tiled.status == "weak" and "tolerance 0.0001" in tiled.message
    assert wg.localize_tiled(tiles, percepts, workers=1).status == "ok"  # the premise: loose, it is ok
    looked = wg.active_localize(world, percepts, lambda d: [], max_looks=0, settings=tight)
    _same(looked.result, alone)


def test_searched_falls_back_only_for_the_queries_gravity_does_not_support(monkeypatch) -> None:
    """``searched`` runs the free search once, for exactly the queries whose gravity pass is not
    kept, and checks every answer's tilt against the gravity given."""
    calls: list[tuple[object, list[int]]] = []
    first = [poseless_result("no_association", f"query {q}", 3, (), {"total": 0.0}, False) for q in range(3)]

    def run(settings: wg.LocalizeSettings, qs: list[int]) -> list[wg.LocalizationResult]:
        calls.append((settings.gravity, list(qs)))
        if settings.gravity is None:
            return [dataclasses.replace(first[q], message=f"free {q}") for q in qs]
        return [first[q] for q in qs]

    unsupported = {1: "too few inliers"}
    monkeypatch.setattr(pipeline, "gravity_unsupported",
                        lambda res, plan, tol, method, n: unsupported.get(int(res.message[-1]), ""))
    out = pipeline.searched(run, wg.LocalizeSettings(), [3, 3, 3])
    assert calls == [("auto", [0, 1, 2]), (None, [1])]
    assert [r.message.split("; ")[-1] for r in out] == ["query 0", "free 1", "query 2"]
    assert out[1].message.startswith("gravity search: too few inliers; answered by the free 3D search")
    calls.clear()
    out = pipeline.searched(run, wg.LocalizeSettings(gravity=None), [3])
    assert calls == [(None, [0])]
