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


@pytest.mark.parametrize(("kwargs", "match"), [
    (dict(disparity_from="dense"), "disparity_from"),
    (dict(disparity_from="outline", disparity_error=-1.0), "disparity_error"),
    (dict(disparity_from="outline", disparity_error={"door": "wide"}), r"disparity_error\['door'\]"),
])
def test_stereo_percepts_refuse_bad_disparity_options(kwargs, match):
    left, right = stereo_pair(False)
    with pytest.raises(pc.PerceptionError, match=match):
        pc.stereo_percepts(left, right, rig(), np.eye(4), **kwargs)

