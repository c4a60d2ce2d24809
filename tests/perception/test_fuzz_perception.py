"""Fuzz every public entry point of :mod:`perception` with nasty arguments.

For each entry point, one argument at a time is replaced by a value hypothesis draws from a
pool of nasty values (NaN, inf, +-1e308, 1e-300, negative, zero, huge ints, bool, None, str,
complex, wrong shapes, empty arrays, non-symmetric and indefinite matrices, values of 1e154 and
more) while the other arguments stay valid. The call must either raise
:class:`perception.PerceptionError` with a message naming the argument, or return a result that
is finite and satisfies its own constraints (SPD covariances, positive sigmas, labels in
range). Any other exception fails the test.
"""

from __future__ import annotations

import dataclasses
import math
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import perception as pc
from perception import PerceptionError

RIG = pc.StereoRig.default((160, 120))
RIG_FILE = str(Path(tempfile.mkdtemp()) / "rig.yaml")
RIG.to_file(RIG_FILE)
RNG_SEED = 7
CHAIN = pc.default_head()
_BOXES, _POSE = pc.random_scene(np.random.default_rng(3))
_LEFT, _RIGHT = pc.render_stereo(pc.StereoRig.default((320, 240)), _POSE, _BOXES, np.random.default_rng(4))
CLASSIFIER = pc.train_classifier(pc.StereoRig.default((320, 240)), np.random.default_rng(0), 3)
RIG320 = pc.StereoRig.default((320, 240))
DETS_L = pc.detect(_LEFT, CLASSIFIER)
DETS_R = pc.detect(_RIGHT, CLASSIFIER)


class _Rng:
    """Marker: a fresh valid Generator is made for every call."""


SCALARS: list[Any] = [
    math.nan, math.inf, -math.inf, 1e308, -1e308, 1e-300, -1e-300, 0, 0.0, -1, -2.5, 1.7, 3, 10**30,
    -(10**30), 2**63, True, False, None, "3", "seed", "", "\0", 1 + 2j, b"x", [], [[]], {}, (), object(),
    np.float64("nan"), np.int64(-5), np.array(2.0), np.array([]), 1e154, 1e200, -1e154,
]


def _mutations(base: Any) -> list[Any]:
    """Nasty variants of a valid array-like ``base``."""
    try:
        a = np.array(base, dtype=np.float64)
    except (TypeError, ValueError):  # a sequence of strings or objects
        seq = list(base)
        return [seq[:-1], seq + seq, seq[::-1] + [None], [*seq[:-1], 3], [*seq[:-1], ""], [*seq[:-1], b"x"]]
    out: list[Any] = [a.tolist()]  # the valid value itself as a list
    if a.size == 0:
        return out + [np.zeros((2, 2)), np.full(3, np.nan)]
    flat = a.ravel()
    for bad in (math.nan, math.inf, -math.inf, 1e308, -1e308, 1e-300, 1e154, -1e200):
        b = flat.copy()
        b[len(b) // 2] = bad
        out.append(b.reshape(a.shape))
    out += [
        a * 1e154, a * 1e300, a * 1e-300, -a, np.zeros_like(a), a.astype(complex) + 1j,
        a.reshape(-1), a[..., :-1] if a.ndim else a, np.zeros((0,) + a.shape[1:]), np.zeros((0, 0)),
        a[None], np.stack([a, a]), a.astype(str), a.astype(bool), a.astype(int),
    ]
    if a.ndim >= 2 and a.shape[-1] == a.shape[-2]:
        tri = np.triu(np.ones(a.shape[-2:]))
        out += [a + tri, -a, a - 2 * np.trace(a, axis1=-2, axis2=-1)[..., None, None] * np.eye(a.shape[-1]),
                np.swapaxes(a, -1, -2) * 1e-300, a * np.nan]
    return out


def nasty(base: Any) -> st.SearchStrategy[Any]:
    pool = SCALARS + (_mutations(base) if isinstance(base, (list, tuple, np.ndarray)) else [])
    strategies = [st.sampled_from(pool), st.floats(), st.integers(-(2**70), 2**70)]
    return st.one_of(*strategies)


def _spd(C: np.ndarray) -> None:
    C = np.asarray(C, dtype=float)
    assert np.all(np.isfinite(C))
    np.testing.assert_allclose(C, np.swapaxes(C, -1, -2), rtol=1e-9, atol=0)
    assert np.all(np.linalg.eigvalsh(C) > 0)


def check_result(out: Any) -> None:
    """Everything numeric in ``out`` is finite and every covariance SPD."""
    if out is None or isinstance(out, (str, bool, np.bool_)):
        return
    if isinstance(out, pc.Percept):
        assert np.all(np.isfinite(out.position)) and math.isfinite(out.sigma) and out.sigma > 0
        assert isinstance(out.views, int) and out.views >= 1
        if out.covariance is not None:
            _spd(out.covariance)
        return
    if isinstance(out, pc.GaussianClassifier):
        assert np.all(np.isfinite(out.means)) and np.all(np.isfinite(out.log_priors))
        _spd(out.covariances)
        assert not np.any(np.isnan(out.thresholds))
        return
    if isinstance(out, pc.Detection):
        assert np.all(np.isfinite(out.centroid_uv)) and np.all(np.isfinite(out.features)) and out.area > 0
        _spd(out.shape_covariance)
        return
    if isinstance(out, pc.KinematicChain):
        for j in out.joints:
            assert np.all(np.isfinite(j.origin))
        assert np.all(np.isfinite(out.ego_from_base)) and np.all(np.isfinite(out.tip_from_camera))
        return
    if dataclasses.is_dataclass(out) and not isinstance(out, type):
        for f in dataclasses.fields(out):
            check_result(getattr(out, f.name))
        return
    if isinstance(out, (list, tuple)):
        for o in out:
            check_result(o)
        return
    if isinstance(out, np.ndarray):
        if out.dtype.kind in "fc":
            assert np.all(np.isfinite(out)), out
        return
    if isinstance(out, (int, float, np.number)):
        assert math.isfinite(float(out))
        return


def call(fn: Callable[..., Any], kwargs: dict[str, Any], fuzzed: str) -> Any:
    kw = {k: (np.random.default_rng(RNG_SEED) if v is _Rng else v) for k, v in kwargs.items()}
    try:
        out = fn(**kw)
    except PerceptionError as exc:
        assert fuzzed in str(exc), f"error for a bad {fuzzed!r} does not name it: {exc}"
        return None
    check_result(out)
    return out


X3 = np.array([[0.1, -0.2, 2.0], [0.3, 0.1, 3.0], [-0.4, 0.2, 4.0]])
UV_L, UV_R = RIG.project(X3)
COV3 = np.diag([0.01, 0.02, 0.03])
PERCEPTS = [pc.Percept("door", [2.0, 0.1 * i, 0.0], 0.01, views=1) for i in range(4)] + [
    pc.Percept("handle", [3.0, 0.0, 1.0], 0.02, COV3 * 0.01)
]
WORLD = np.array([[2.0, 0.0, 0.5], [3.0, 1.0, 1.0], [4.0, -1.0, 0.0]])
I4 = np.eye(4)
FEATS = np.random.default_rng(0).normal(size=(20, 3))
LABELS = ["a"] * 10 + ["b"] * 10
K = RIG.K1


def _rng_pool() -> st.SearchStrategy[Any]:
    return st.sampled_from(SCALARS + ["seed", 0, np.random.RandomState(0), np.random.default_rng])


_DEPTH = np.full((120, 160), 2.5)
_DEPTH[40:70, 50:90] = 1.8
_MASK = np.zeros((120, 160), bool)
_MASK[42:68, 52:88] = True
RGBD_DETS = [pc.Detection("door", mask=_MASK, score=0.8), pc.Detection("knob", box=(48, 38, 91, 71))]
STEREO_L = [pc.Detection("door", centroid_uv=uv, area=60.0) for uv in UV_L]
STEREO_R = [pc.Detection("door", centroid_uv=uv, area=60.0) for uv in UV_R]

_BLOCK = np.zeros((240, 320), dtype=bool)
_BLOCK[80:160, 120:180] = True
OUTLINE_L = pc.Detection("door", mask=_BLOCK)
OUTLINE_R = pc.Detection("door", mask=np.roll(_BLOCK, -8, axis=1))
CASES: dict[str, tuple[Callable[..., Any], dict[str, Any]]] = {
    "Percept": (pc.Percept, dict(type="door", position=[1.0, 2.0, 3.0], sigma=0.1, covariance=COV3, views=2)),
    "fuse_percepts": (pc.fuse_percepts, dict(percepts=PERCEPTS, bandwidth=0.2, min_views=2, max_iter=50,
                                             tol=1e-6)),
    "fuse_percepts_report": (pc.fuse_percepts_report, dict(percepts=PERCEPTS, bandwidth=0.2, min_views=2,
                                                           max_iter=50, tol=1e-6)),
    "mean_shift_modes": (pc.mean_shift_modes, dict(points=X3, bandwidth=0.5, weights=[1.0, 2.0, 3.0],
                                                   max_iter=20, tol=1e-6)),
    "depth_sigma": (pc.depth_sigma, dict(rho=[1.0, 2.0], depth_factor=1000.0)),
    "disparity": (pc.disparity, dict(rho=[1.0, 2.0], focal_px=500.0, baseline=0.1)),
    "perception_depth": (pc.perception_depth, dict(points=X3, camera_center=[0.0, 0.0, 0.0],
                                                   viewing_direction=[0.0, 0.0, 1.0])),
    "pixel_footprint": (pc.pixel_footprint, dict(rho=[1.0, 2.0], hfov=1.0, vfov=0.8, width=640, height=480)),
    "triangulation_covariance": (pc.triangulation_covariance, dict(rig=RIG, uv_left=UV_L, uv_right=UV_R,
                                                                   pixel_sigma=0.5)),
    "class_bandwidth": (pc.class_bandwidth, dict(vertices=X3 + np.eye(3))),
    "check_transform": (pc.check_transform, dict(name="value", value=I4, atol=1e-6)),
    "Joint": (pc.Joint, dict(name="j", axis="z", origin=I4)),
    "KinematicChain": (pc.KinematicChain, dict(joints=CHAIN.joints, ego_from_base=I4, tip_from_camera=I4,
                                               right_eye=CHAIN.right_eye)),
    "default_head": (pc.default_head, dict(baseline=0.093)),
    "percept_covariance": (pc.percept_covariance, dict(chain=CHAIN, angles=np.zeros(CHAIN.n_joints),
                                                       point_camera=[0.1, 0.2, 2.0], point_cov_camera=COV3,
                                                       encoder_sigma=0.001)),
    "StereoRig": (pc.StereoRig, dict(K1=K, D1=np.zeros(5), K2=K, D2=np.zeros(5), R=np.eye(3),
                                     T=[-0.1, 0.0, 0.0], image_size=(160, 120))),
    "StereoRig.from_opencv": (pc.StereoRig.from_opencv, dict(K1=K, D1=None, K2=K, D2=np.zeros((1, 5)),
                                                             R=np.eye(3), T=[[-0.1], [0.0], [0.0]],
                                                             image_size=(160, 120))),
    "StereoRig.default": (pc.StereoRig.default, dict(image_size=(160, 120), baseline=0.1, hfov_deg=60.0)),
    "StereoRig.project": (RIG.project, dict(points_left=X3)),
    "StereoRig.in_view": (RIG.in_view, dict(points_left=X3)),
    "StereoRig.triangulate": (RIG.triangulate, dict(uv_left=UV_L, uv_right=UV_R)),
    "StereoRig.normalized": (RIG.normalized, dict(uv_left=UV_L, uv_right=UV_R)),
    "StereoRig.rectify": (RIG.rectify, dict(alpha=0.5)),
    "StereoRig.from_file": (pc.StereoRig.from_file, dict(path=RIG_FILE)),
    "simulate_percepts": (pc.simulate_percepts, dict(types=["door", "handle", "door"], world_positions=WORLD,
                                                     world_from_ego=I4, rng=_Rng, depth_factor=1000.0,
                                                     max_range=8.0, hfov_deg=120.0, n_false=2,
                                                     false_types=["door"], miss_rate=0.1, min_sigma=1e-4)),
    "simulate_scan": (pc.simulate_scan, dict(types=["door", "handle", "door"], world_positions=WORLD,
                                             world_from_ego=I4, rng=_Rng, chain=CHAIN, rig=RIG, n_views=3,
                                             depth_factor=1000.0, miss_rate=0.1, false_rate=0.1,
                                             max_range=8.0, return_truth=True, min_sigma=1e-4,
                                             yaw_deg=(-30.0, 30.0), pitch_deg=(-5.0, 5.0))),
    "Box": (pc.Box, dict(center=[1.0, 2.0, 0.5], size=[0.5, 0.1, 1.0], rotation=np.eye(3),
                         color=[10, 20, 30], type="door")),
    "scene_boxes": (pc.scene_boxes, dict(types=["door", "handle"], positions=WORLD[:2],
                                         rotations=np.stack([np.eye(3)] * 2), sizes=None, colors=None)),
    "random_scene": (pc.random_scene, dict(rng=_Rng, n_doors=(1, 2), n_clutter=(0, 1), distance=(2.5, 4.0),
                                           max_door_yaw_deg=30.0)),
    "render_stereo": (pc.render_stereo, dict(rig=RIG, camera_from_world=_POSE, boxes=_BOXES, rng=_Rng,
                                             background=(150, 120, 95), light_noise=0.05, pixel_noise=2.0,
                                             ambient=0.45, light_direction=(-0.8, -0.25, 0.55))),
    "Detection": (pc.Detection, dict(type="door", centroid_uv=[10.0, 20.0], area=50.0,
                                     features=[1.0, 2.0, 3.0], log_likelihood=-3.0,
                                     shape_covariance=[[4.0, 1.0], [1.0, 3.0]])),
    "GaussianClassifier": (pc.GaussianClassifier, dict(classes=("a", "b"), means=np.zeros((2, 3)),
                                                       covariances=np.stack([np.eye(3)] * 2),
                                                       log_priors=np.log([0.5, 0.5]),
                                                       thresholds=[-10.0, -np.inf])),
    "GaussianClassifier.fit": (pc.GaussianClassifier.fit, dict(features=FEATS, labels=LABELS,
                                                               regularization=1e-4, reject_quantile=0.01,
                                                               threshold_margin=3.0)),
    "GaussianClassifier.predict": (CLASSIFIER.predict, dict(features=np.zeros((2, 7)))),
    "detect": (pc.detect, dict(image=_LEFT, classifier=CLASSIFIER, min_area=12, exclude_border=True)),
    "rgbd_percepts": (pc.rgbd_percepts, dict(detections=RGBD_DETS, depth=_DEPTH, K=K, ego_from_camera=I4,
                                             depth_noise=1.5e-3, depth_correlation_px=8.0, centre_offset=0.01,
                                             min_pixels=20, keep_cut_off=False)),
    "stereo_percepts": (pc.stereo_percepts, dict(left=STEREO_L, right=STEREO_R, rig=RIG, ego_from_camera=I4,
                                                 centre_offset={"door": 0.01}, depth_factor=None,
                                                 pixel_sigma=None, max_epipolar_px=2.0, min_depth=0.3,
                                                 keep_cut_off=False, disparity_from="outline",
                                                 disparity_error={"door": 0.5})),
    "DisparityError": (pc.DisparityError, dict(bias_px=0.1, sd_px=0.4, ends_fraction=0.5)),
    "outline_disparity": (pc.outline_disparity, dict(rig=RIG320, left=OUTLINE_L, right=OUTLINE_R,
                                                     rectification=None, at=[150.0, 120.0])),
    "fit_disparity_errors": (pc.fit_disparity_errors, dict(types=["door"] * 6,
                                                           measured_px=[10.0, 11, 12, 10, 11, 12],
                                                           true_px=[10.5] * 6, known_sd_px=[0.1] * 6,
                                                           ends_differ_px=[0.0, 1, 2, 0, 1, 2], min_pairs=5)),
    "percept_bandwidths": (pc.percept_bandwidths, dict(percepts=PERCEPTS, n_sigma=3.0, minimum=0.02)),
    "CentreOffset": (pc.CentreOffset, dict(depth=0.01, depth_sd=0.005, lateral_sd=0.01)),
    "StereoMatch": (pc.StereoMatch, dict(left=0, right=1, epipolar_px=0.5)),
    "match_stereo": (pc.match_stereo, dict(rig=RIG320, left_dets=DETS_L, right_dets=DETS_R,
                                           max_epipolar_px=2.0, max_log_area_ratio=1.0)),
    "recognize": (pc.recognize, dict(rig=RIG320, left=_LEFT, right=_RIGHT, classifier=CLASSIFIER,
                                     depth_factor=None, disparity_std_px=0.3, pixel_sigma=None,
                                     centroid_offset_scale=0.08, ego_from_camera=None, max_epipolar_px=2.0,
                                     min_area=12)),
}

SLOW = {"train_classifier", "recognize", "render_stereo", "simulate_scan", "detect", "fuse_percepts"}


def test_every_public_entry_point_is_fuzzed() -> None:
    # result records and a constant take no input of their own
    names = {n for n in pc.__all__ if not n.endswith("Error")} - {"Rectification", "DetectionPercepts",
                                                                  "Dropped", "OBJECT_VIEW", "FusionDrop",
                                                                  "FusionReport", "OutlineDisparity",
                                                                  "DISPARITY_SD_PX",
                                                                  "DISPARITY_ENDS_FRACTION"}
    covered = {c.split(".")[0] for c in CASES} | {"train_classifier"}
    assert names <= covered, sorted(names - covered)


@pytest.mark.parametrize("case", sorted(CASES))
def test_valid_base_call_succeeds(case: str) -> None:
    fn, kwargs = CASES[case]
    out = call(fn, kwargs, "<none>")
    assert out is not None or case in {"recognize"}


@pytest.mark.parametrize("case", sorted(CASES))
@given(data=st.data())
def test_fuzz_entry_point(case: str, data: st.DataObject) -> None:
    fn, kwargs = CASES[case]
    arg = data.draw(st.sampled_from(sorted(kwargs)), label="argument")
    base = kwargs[arg]
    value = data.draw(_rng_pool() if base is _Rng else nasty(base), label=arg)
    call(fn, {**kwargs, arg: value}, arg)


@settings(max_examples=12)
@given(arg=st.sampled_from(["rig", "rng", "n_scenes", "min_area", "regularization"]), data=st.data())
def test_fuzz_train_classifier(arg: str, data: st.DataObject) -> None:
    kwargs: dict[str, Any] = dict(rig=RIG320, rng=_Rng, n_scenes=2, min_area=12, regularization=1e-4)
    value = data.draw(_rng_pool() if arg == "rng" else st.sampled_from(SCALARS), label=arg)
    call(pc.train_classifier, {**kwargs, arg: value}, arg)


@settings(max_examples=40)
@given(
    sigma=st.sampled_from([1e-300, 1e-160, 1e-150, 1e-20, 1.0, 1e20, 1e150, 1e160, 1e300]),
    shift=st.sampled_from([0.0, 1e6, 1e8, 1e9 - 1.0]),  # positions are capped at 1e9 m
    bandwidth=st.sampled_from([1e-300, 1e-100, 0.1, 1e100, 1e300]),
)
def test_fuse_extreme_scales(sigma: float, shift: float, bandwidth: float) -> None:
    ps = [pc.Percept("door", [shift + 0.01 * i, 0.0, 1.0], sigma) for i in range(3)]
    out = call(pc.fuse_percepts, dict(percepts=ps, bandwidth=bandwidth), "")
    if out is not None:
        assert sum(p.views for p in out) <= 3


@settings(max_examples=40)
@given(
    scale=st.sampled_from([1e-300, 1e-200, 1e-20, 1.0, 1e20, 1e200, 1e300]),
    M=st.sampled_from(
        [np.eye(3), np.zeros((3, 3)), -np.eye(3), np.eye(3) + 2 * np.triu(np.ones((3, 3)), 1),
         np.diag([1.0, 1.0, 0.0]), np.diag([1.0, 1.0, -1e-9]), np.eye(3) * (1 + 1j)]
    ),
)
def test_percept_covariance_spd_or_named_error(scale: float, M: np.ndarray) -> None:
    out = call(pc.Percept, dict(type="door", position=[1.0, 0.0, 0.0], sigma=0.1, covariance=M * scale),
               "covariance")
    if out is not None:
        _spd(out.covariance)


@pytest.mark.parametrize("bad", [math.nan, None, 1.7, "2", True, 2.0])
def test_int_fields_reject_non_integers(bad: Any) -> None:
    for fn, kw, name in [
        (pc.Percept, dict(type="door", position=[1.0, 0, 0], sigma=0.1, views=bad), "views"),
        (pc.fuse_percepts, dict(percepts=PERCEPTS, min_views=bad), "min_views"),
        (pc.fuse_percepts, dict(percepts=PERCEPTS, max_iter=bad), "max_iter"),
        (pc.simulate_scan, dict(types=["door"], world_positions=WORLD[:1], world_from_ego=I4,
                                rng=np.random.default_rng(0), n_views=bad), "n_views"),
        (pc.StereoRig.default, dict(image_size=(bad, 120)), "image_size"),
    ]:
        with pytest.raises(PerceptionError, match=name):
            fn(**kw)


def test_project_far_point_names_index() -> None:
    with pytest.raises(PerceptionError, match=r"points_left\[1\]"):
        RIG.project([[0.0, 0.0, 1.0], [1e300, 0.0, 1e300]])


def test_rng_seed_string_is_a_clear_error() -> None:
    with pytest.raises(PerceptionError, match="rng must be a numpy.random.Generator"):
        pc.simulate_percepts(["door"], WORLD[:1], I4, "seed")


@pytest.mark.parametrize("arg", ["width", "height"])
def test_pixel_footprint_huge_image_size_is_named(arg: str) -> None:
    """Audit: an image size of 10**400 pixels overflowed float conversion; the message named no argument."""
    kwargs = {"rho": 2.0, "hfov": 1.0, "vfov": 1.0, "width": 640, "height": 480, arg: 10**400}
    with pytest.raises(PerceptionError, match=arg):
        pc.pixel_footprint(**kwargs)


def test_a_tiny_disparity_error_is_named_when_it_sets_both_defaults() -> None:
    """Found by the 'dev' hunt: with depth_factor and pixel_sigma both derived from a tiny
    disparity_std_px, the sigma check named only the derived values, not the argument given."""
    with pytest.raises(pc.PerceptionError, match=r"both come from disparity_std_px = 5\.96"):
        pc.recognize(RIG320, _LEFT, _RIGHT, CLASSIFIER, disparity_std_px=5.960464477539063e-08)
