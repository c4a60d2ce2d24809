"""Outline disparity and the disparity error model.

Expected values come from the masks' construction (a rectangle shifted by a known number of
pixels, a planar rectangle at a known depth projected through a known rig), never from the code
under test.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import perception as pc

W, H = 320, 240


def rig(rotated: bool = False) -> pc.StereoRig:
    K = np.array([[300.0, 0.0, 159.5], [0.0, 300.0, 119.5], [0.0, 0.0, 1.0]])
    if not rotated:
        return pc.StereoRig(K, np.zeros(5), K, np.zeros(5), np.eye(3), np.array([-0.1, 0.0, 0.0]), (W, H))
    R = Rotation.from_euler("xyz", [0.6, -1.2, 0.8], degrees=True).as_matrix()
    D = np.array([-0.05, 0.01, 0.0, 0.0, 0.0])
    return pc.StereoRig(K, D, K * [[1.01], [1.01], [1.0]], D, R, np.array([-0.1, 0.002, 0.001]), (W, H))


def rectangle(u0: int, v0: int, u1: int, v1: int) -> np.ndarray:
    mask = np.zeros((H, W), dtype=bool)
    mask[v0:v1 + 1, u0:u1 + 1] = True
    return mask


def detection(mask: np.ndarray, kind: str = "door") -> pc.Detection:
    return pc.Detection(kind, mask=mask)


def test_shifted_rectangle_gives_its_shift():
    left = detection(rectangle(100, 60, 180, 170))
    right = detection(rectangle(88, 60, 168, 170))  # 12 px of disparity
    out = pc.outline_disparity(rig(), left, right)
    assert out is not None
    np.testing.assert_allclose(out.uv_right, np.asarray(left.centroid_uv) - [12.0, 0.0], atol=1e-6)
    assert out.rows == 111 and out.kept_fraction == 1.0
    assert 0.0 < out.sd < 0.1


def test_rows_an_occluder_moved_are_trimmed():
    left = rectangle(100, 60, 180, 170)
    right = rectangle(88, 60, 168, 170)
    right[60:90, 88:96] = False  # a nearer occluder hides the left end of 30 rows in the right eye
    d_left, d_right = detection(left), detection(right)
    out = pc.outline_disparity(rig(), d_left, d_right, at=[140.0, 115.0])
    assert out is not None
    np.testing.assert_allclose(out.uv_right, [128.0, 115.0], atol=1e-6)
    assert out.kept_fraction == pytest.approx(1.0 - 30 / 222, abs=1e-9)
    # the centroids see the hidden rows: their difference errs by more than 1 px
    assert abs((d_left.centroid_uv[0] - d_right.centroid_uv[0]) - 12.0) > 1.0



def test_an_end_one_eye_sees_cut_is_reported_and_widens_the_default_error():
    """A vertical occluder hides the left 4 columns of every row in the right eye: the trim cannot
    see it (every row moves alike); the ends' difference (8 px against 12) is reported, and the
    default error model takes half of it as a standard deviation, which covers the true 12 px."""
    left = rectangle(100, 60, 180, 170)
    right = rectangle(88, 60, 168, 170)
    right[:, 88:92] = False  # the right mask's left end: 92 instead of 88
    out = pc.outline_disparity(rig(), detection(left), detection(right))
    assert out is not None and out.kept_fraction == 1.0
    assert out.ends_differ_px == pytest.approx(8.0 - 12.0, abs=1e-9)
    assert out.sd < 0.5  # the rows agree with each other
    sd = np.sqrt(pc.DisparityError().variance(out))
    assert sd >= 2.0  # half the ends' difference
    assert abs(out.disparity - 12.0) <= 1.5 * sd
    assert pc.DisparityError(0.0, 0.0, 0.0).variance(out) == pytest.approx(out.sd ** 2)
    whole = pc.outline_disparity(rig(), detection(left), detection(rectangle(88, 60, 168, 170)))
    assert whole is not None and whole.ends_differ_px == 0.0


def test_a_mask_drawn_wider_all_round_is_no_cut_end():
    """The right mask one pixel wider on every side (a detector's edge): the ends differ by 2 px
    each way and the rows by one at top and bottom, which says it is no occluder: the ends'
    difference is 0."""
    left = rectangle(100, 60, 180, 170)
    wider = rectangle(87, 59, 169, 171)
    out = pc.outline_disparity(rig(), detection(left), detection(wider))
    assert out is not None
    assert out.ends_differ_px == pytest.approx(0.0, abs=1e-9)
    # ends at 13 and 11 px: their harmonic mean (a slanted face's) 11.92, not 12
    assert out.disparity == pytest.approx(2.0 / (1.0 / 13.0 + 1.0 / 11.0), abs=1e-9)
    narrower = pc.outline_disparity(rig(), detection(left), detection(rectangle(89, 61, 167, 169)))
    assert narrower is not None and narrower.ends_differ_px == pytest.approx(0.0, abs=1e-9)

def test_plane_through_a_calibrated_rig_triangulates_to_its_depth():
    """A fronto-parallel rectangle 2.5 m away, projected through a rotated, distorted rig."""
    import cv2

    r = rig(rotated=True)
    corners = np.array([[-0.3, -0.2, 2.5], [0.3, -0.2, 2.5], [0.3, 0.25, 2.5], [-0.3, 0.25, 2.5]])
    # densely sampled edges so that the distorted outline is drawn as the curve it is
    t = np.linspace(0.0, 1.0, 60, endpoint=False)[:, None]
    outline = np.vstack([a + t * (b - a) for a, b in zip(corners, np.roll(corners, -1, axis=0), strict=True)])
    uv_l, uv_r = r.project(outline)
    masks = []
    for uv in (uv_l, uv_r):
        m = np.zeros((H, W), dtype=np.uint8)
        cv2.fillPoly(m, [np.rint(uv).astype(np.int32)], 1)
        masks.append(m.astype(bool))
    left, right = detection(masks[0]), detection(masks[1])
    out = pc.outline_disparity(r, left, right)
    assert out is not None and out.rows > 50
    X = r.triangulate(np.asarray(left.centroid_uv)[None, :], out.uv_right[None, :])[0]
    assert X[2] == pytest.approx(2.5, rel=0.02)
    # the disparity error of 1 px moves the match along its epipolar line: by about 1 px
    assert np.linalg.norm(out.duv_right) == pytest.approx(1.0, rel=0.05)


def test_no_outline_without_masks_or_shared_rows():
    box_only = pc.Detection("door", box=[10, 10, 40, 40])
    assert pc.outline_disparity(rig(), box_only, box_only) is None
    top, bottom = detection(rectangle(100, 10, 150, 40)), detection(rectangle(100, 100, 150, 140))
    assert pc.outline_disparity(rig(), top, bottom) is None
    with pytest.raises(pc.PerceptionError, match="rig"):
        pc.outline_disparity("rig", top, top)
    with pytest.raises(pc.PerceptionError, match="right"):
        pc.outline_disparity(rig(), top, "bottom")


def test_fit_recovers_bias_and_spread():
    rng = np.random.default_rng(3)
    n = 4000
    true = rng.uniform(10, 40, 2 * n)
    types = ["door"] * n + ["knob"] * n
    err = np.r_[0.3 + 0.8 * rng.standard_normal(n), -0.1 + 0.3 * rng.standard_normal(n)]
    fit = pc.fit_disparity_errors(types, true + err, true)
    assert fit["door"].bias_px == pytest.approx(0.3, abs=0.05)
    assert fit["door"].sd_px == pytest.approx(0.8, abs=0.04)
    assert fit["knob"].sd_px == pytest.approx(0.3, abs=0.02)
    # what is already modelled is not counted twice
    known = np.full(2 * n, 0.2)
    assert pc.fit_disparity_errors(types, true + err, true, known)["door"].sd_px == pytest.approx(
        np.sqrt(0.8 ** 2 - 0.2 ** 2), abs=0.04)
    assert set(pc.fit_disparity_errors(types[: n + 3], (true + err)[: n + 3], true[: n + 3])) == {"door"}


@pytest.mark.parametrize(("kwargs", "match"), [
    (dict(types=["a", "b"], measured_px=[1.0], true_px=[1.0, 2.0]), "measured_px"),
    (dict(types=["a"], measured_px=[np.nan], true_px=[1.0]), "measured_px"),
    (dict(types=["a"], measured_px=[1.0], true_px=[1.0], known_sd_px=[-1.0]), r"known_sd_px\[0\]"),
    (dict(types=["a"], measured_px=[1.0], true_px=[1.0], min_pairs=0), "min_pairs"),
])
def test_fit_refuses_bad_input(kwargs, match):
    with pytest.raises(pc.PerceptionError, match=match):
        pc.fit_disparity_errors(**kwargs)


def test_disparity_error_checks_its_fields():
    with pytest.raises(pc.PerceptionError, match="sd_px"):
        pc.DisparityError(0.0, -1.0)
    with pytest.raises(pc.PerceptionError, match="bias_px"):
        pc.DisparityError(np.inf)


def stereo_pair(occluded: bool) -> tuple[list[pc.Detection], list[pc.Detection]]:
    left = rectangle(100, 60, 180, 170)
    right = rectangle(88, 60, 168, 170)
    if occluded:
        right[60:90, 88:96] = False
    return [detection(left)], [detection(right)]


def test_stereo_percepts_from_the_outline():
    r = rig()
    ego = np.eye(4)
    # 12 px at f 300 px and 0.1 m: 2.5 m along the optical axis
    for occluded in (False, True):
        left, right = stereo_pair(occluded)
        out = pc.stereo_percepts(left, right, r, ego, centre_offset=0.0, disparity_from="outline")
        assert out.percepts[0].position[2] == pytest.approx(2.5, rel=1e-3)
    left, right = stereo_pair(True)
    paper = pc.stereo_percepts(left, right, r, ego, centre_offset=0.0)  # the default: centroids
    assert abs(paper.percepts[0].position[2] - 2.5) > 0.1  # the hidden rows move the centroid
    outline = dict(centre_offset=0.0, disparity_from="outline")
    wide = pc.stereo_percepts(left, right, r, ego, **outline, disparity_error=3.0)
    narrow = pc.stereo_percepts(left, right, r, ego, **outline, disparity_error={"door": 0.1})
    assert wide.percepts[0].covariance[2, 2] > 10 * narrow.percepts[0].covariance[2, 2]
    biased = pc.stereo_percepts(left, right, r, ego, **outline,
                                disparity_error=pc.DisparityError(bias_px=2.0))
    assert biased.percepts[0].position[2] == pytest.approx(0.1 * 300.0 / 10.0, rel=1e-3)


def test_stereo_percepts_choose_the_disparity_per_type():
    """A mapping names the source per type; types it leaves out take the centroids."""
    r = rig()
    left, right = stereo_pair(True)
    knob_l, knob_r = stereo_pair(True)  # the same masks, typed a knob
    left.append(pc.Detection("knob", mask=knob_l[0].mask))
    right.append(pc.Detection("knob", mask=knob_r[0].mask))
    out = pc.stereo_percepts(left, right, r, np.eye(4), centre_offset=0.0, disparity_from={"door": "outline"})
    depth = {p.type: p.position[2] for p in out.percepts}
    assert depth["door"] == pytest.approx(2.5, rel=1e-3)  # the outline trims the hidden rows
    assert abs(depth["knob"] - 2.5) > 0.1  # the centroids do not
    both = pc.stereo_percepts(left, right, r, np.eye(4), centre_offset=0.0,
                              disparity_from={"door": "outline", "knob": "outline"})
    assert all(p.position[2] == pytest.approx(2.5, rel=1e-3) for p in both.percepts)


@pytest.mark.parametrize(("kwargs", "match"), [
    (dict(disparity_from="dense"), "disparity_from"),
    (dict(disparity_from={"door": "dense"}), r"disparity_from\['door'\]"),
    (dict(disparity_from={"": "outline"}), "disparity_from key"),
    (dict(disparity_from="outline", disparity_error=-1.0), "disparity_error"),
    (dict(disparity_from="outline", disparity_error={"door": "wide"}), r"disparity_error\['door'\]"),
])
def test_stereo_percepts_refuse_bad_disparity_options(kwargs, match):
    left, right = stereo_pair(False)
    with pytest.raises(pc.PerceptionError, match=match):
        pc.stereo_percepts(left, right, rig(), np.eye(4), **kwargs)



def test_rendered_stereo_percepts_lie_within_their_covariance(tmp_path):
    """Stereo percepts of a rendered room (the scan's defaults: the measured disparity source and
    errors per type) against the bodies' true centres: the mean 3-D NEES (3 for an honest
    covariance) of no type far above (over-confident), and of all together near 3."""
    import os

    os.environ.setdefault("MUJOCO_GL", "egl")
    pytest.importorskip("mujoco")
    from perception.mujoco import MujocoScene

    from .test_mujoco_look import robot, room_xml

    path = tmp_path / "room.xml"
    path.write_text(room_xml())
    scene = MujocoScene(path)
    try:
        nees: dict[str, list[float]] = {}
        rng = np.random.default_rng(5)
        for pose in (robot(0.5, -0.5, 180.0), robot(0.0, 0.5, 150.0), robot(-0.5, 0.0, -120.0)):
            scan = scene.scan(pose, "stereo", 8, rng=rng, image_size=(W, H), mask_jitter_px=1)
            ego_from_world = np.linalg.inv(pose)
            for p, k in zip(scan.percepts, scan.percept_truth, strict=True):
                truth = ego_from_world[:3, :3] @ scene.positions[k] + ego_from_world[:3, 3]
                e = np.asarray(p.position) - truth
                nees.setdefault(p.type, []).append(float(e @ np.linalg.solve(p.covariance, e)))
    finally:
        scene.close()
    means = {t: float(np.mean(v)) for t, v in nees.items() if len(v) >= 4}
    pooled = float(np.mean([x for v in nees.values() for x in v]))
    assert len(means) >= 2, nees
    # no type over-confident (mean NEES of 3 dof at most 9); small parts sit on the centre offsets'
    # floors (1 cm across, 5 mm along), so under-confidence is bounded over all types together
    assert all(m <= 9.0 for m in means.values()), means
    assert 0.6 <= pooled <= 6.0, (pooled, means)


@pytest.mark.parametrize(("s_true", "c_true", "t_true"), [(0.4, 0.0, 0.0), (0.0, 0.5, 0.6), (0.3, 0.3, 0.5)])
def test_split_spread_recovers_the_spreads_it_was_drawn_with(s_true, c_true, t_true):
    """Residuals drawn as ``b_object + e`` with ``e ~ N(0, own^2 + s^2 + (c ends)^2)``, ``b ~ N(0,
    t^2)``, views of unequal own errors and ends' differences (one in five 3 px, as an occluded
    end gives): the split finds ``s``, ``c`` and ``t`` to within the sampling error of 400
    objects seen 6 times."""
    from perception.frontend.outline import split_spread

    rng = np.random.default_rng(11)
    n_obj, per = 400, 6
    group = np.repeat(np.arange(n_obj), per)
    own = rng.uniform(0.05, 0.2, group.size)
    ends = np.where(rng.random(group.size) < 0.2, 3.0, 0.1) * rng.choice([-1.0, 1.0], group.size)
    sd = np.sqrt(own ** 2 + s_true ** 2 + (c_true * ends) ** 2)
    res = rng.normal(0.0, t_true, n_obj)[group] + rng.normal(0.0, 1.0, group.size) * sd
    s, t = split_spread(group, res, own, ends, c_true)
    assert s ** 2 == pytest.approx(s_true ** 2, abs=0.03)  # variances: a spread of 0 estimates above it
    assert t ** 2 == pytest.approx(t_true ** 2, abs=0.06)


def test_split_spread_of_objects_seen_once_takes_it_all_as_shared():
    from perception.frontend.outline import split_spread

    rng = np.random.default_rng(12)
    res = rng.normal(0.0, 0.5, 2000)
    s, t = split_spread(np.arange(2000), res, np.full(2000, 0.3), np.zeros(2000))
    assert s == 0.0 and t == pytest.approx(0.4, abs=0.03)  # sqrt(0.5^2 - 0.3^2)


def test_fit_disparity_errors_with_ends_fits_their_fraction():
    rng = np.random.default_rng(13)
    n = 3000
    ends = rng.choice([0.0, 0.5, 4.0], n)
    true = rng.uniform(10.0, 40.0, n)
    measured = true + 0.2 + rng.normal(0.0, 1.0, n) * np.hypot(0.3, 0.4 * ends)
    fit = pc.fit_disparity_errors(["door"] * n, measured, true, ends_differ_px=ends)["door"]
    assert fit.bias_px == pytest.approx(0.2, abs=0.03)
    assert fit.sd_px == pytest.approx(0.3, abs=0.03)
    assert fit.ends_fraction == pytest.approx(0.4, abs=0.03)
    assert pc.fit_disparity_errors(["door"] * n, measured, true)["door"].ends_fraction == 0.0
