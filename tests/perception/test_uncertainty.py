"""Image-to-space uncertainty: eqs. 6-8, pixel footprint, triangulation covariance, bandwidth."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from perception import (
    PerceptionError,
    StereoRig,
    class_bandwidth,
    depth_sigma,
    disparity,
    perception_depth,
    pixel_footprint,
    triangulation_covariance,
)

finite = st.floats(-50, 50, allow_nan=False)


@given(
    x=st.tuples(finite, finite, finite),
    c=st.tuples(finite, finite, finite),
    e=st.tuples(finite, finite, finite).filter(lambda v: math.hypot(*v) > 1e-3),
)
def test_perception_depth_eq7(x, c, e) -> None:
    n = math.sqrt(e[0] ** 2 + e[1] ** 2 + e[2] ** 2)
    expected = sum((x[k] - c[k]) * e[k] / n for k in range(3))
    assert perception_depth(x, c, e) == pytest.approx(expected, rel=1e-9, abs=1e-9)


def test_perception_depth_vectorised() -> None:
    X = np.array([[1.0, 2.0, 3.0], [0.0, 0.0, 5.0], [-1.0, 4.0, 0.5]])
    out = perception_depth(X, [0.0, 1.0, 0.0], [0.0, 0.0, 2.0])
    np.testing.assert_allclose(out, [3.0, 5.0, 0.5])


@given(rho=st.floats(1e-3, 20), df=st.floats(1.0, 1e5))
def test_depth_sigma_eq6(rho: float, df: float) -> None:
    assert depth_sigma(rho, df) == pytest.approx(rho * rho / df, rel=1e-12, abs=0)


@pytest.mark.parametrize("rho", [-2.0, 0.0, -1e-300, [1.0, -0.5]])
def test_depth_sigma_rejects_non_positive_depth(rho) -> None:
    # depth_sigma(-2.0, 1000) once returned 0.004; a depth must be > 0
    with pytest.raises(PerceptionError, match="rho"):
        depth_sigma(rho, 1000.0)


@given(rho=st.floats(0.05, 50), f=st.floats(10, 5000), b=st.floats(0.01, 1))
def test_disparity_eq8(rho: float, f: float, b: float) -> None:
    assert disparity(rho, f, b) == pytest.approx(f * b / rho, rel=1e-12)


def test_disparity_matches_rig_projection() -> None:
    """Eq. 8 is the horizontal pixel offset of a parallel rig's two images."""
    rig = StereoRig.default(baseline=0.12)
    z = np.array([0.5, 1.0, 2.5, 7.0])
    X = np.column_stack([0.1 * z, -0.05 * z, z])
    uv1, uv2 = rig.project(X)
    np.testing.assert_allclose(uv1[:, 0] - uv2[:, 0], disparity(z, rig.focal_px, rig.baseline), rtol=1e-9)


def test_pixel_footprint() -> None:
    hfov, vfov = np.radians(60.0), np.radians(45.0)
    rho = np.array([0.5, 2.0, 8.0])
    expected = [r * r * math.tan(hfov / 640) * math.tan(vfov / 480) for r in rho]
    np.testing.assert_allclose(pixel_footprint(rho, hfov, vfov, 640, 480), expected, rtol=1e-12)
    assert pixel_footprint(2.0, hfov, vfov, 640, 480) == pytest.approx(expected[1])


def test_triangulation_covariance_front_parallel_depth() -> None:
    """Depth std of a parallel rig: Z^2 / (f b) * sqrt(2) sigma_px (disparity = u_L - u_R)."""
    rig = StereoRig.default()
    z = np.array([1.0, 3.0, 6.0])
    X = np.column_stack([np.zeros(3), np.zeros(3), z])
    uv1, uv2 = rig.project(X)
    C = triangulation_covariance(rig, uv1, uv2, pixel_sigma=0.5)
    assert C.shape == (3, 3, 3)
    expected = z**2 / (rig.focal_px * rig.baseline) * math.sqrt(2.0) * 0.5
    np.testing.assert_allclose(np.sqrt(C[:, 2, 2]), expected, rtol=1e-5)
    np.testing.assert_allclose(C, np.transpose(C, (0, 2, 1)), atol=1e-15)


def test_triangulation_covariance_monte_carlo() -> None:
    R, _ = cv2.Rodrigues(np.array([0.02, -0.03, 0.01]))
    base = StereoRig.default()
    rig = StereoRig.from_opencv(
        base.K1, [-0.15, 0.03, 0.0, 0.0, 0.0], base.K2, None, R, [-0.093, 0.001, 0], (640, 480)
    )
    X = np.array([[0.3, -0.1, 1.5], [-0.5, 0.2, 3.0]])
    uv1, uv2 = rig.project(X)
    C = triangulation_covariance(rig, uv1, uv2, pixel_sigma=0.3)
    rng = np.random.default_rng(0)
    m = 20000
    for k in range(2):
        n1 = uv1[k] + rng.normal(0, 0.3, (m, 2))
        n2 = uv2[k] + rng.normal(0, 0.3, (m, 2))
        S = np.cov(rig.triangulate(n1, n2).T)
        # loose: sampling error ~2% plus the non-linearity of triangulation
        np.testing.assert_allclose(np.sqrt(np.diag(S)), np.sqrt(np.diag(C[k])), rtol=0.06)
        corr = C[k][0, 2] / math.sqrt(C[k][0, 0] * C[k][2, 2])
        assert S[0, 2] / math.sqrt(S[0, 0] * S[2, 2]) == pytest.approx(corr, abs=0.05)


def test_class_bandwidth() -> None:
    rng = np.random.default_rng(1)
    V = rng.normal(size=(30, 3)) * [0.1, 0.02, 0.05]
    mean = [sum(V[i, a] for i in range(30)) / 30 for a in range(3)]
    expected = [[sum((V[i, a] - mean[a]) * (V[i, b] - mean[b]) for i in range(30)) / 30 for b in range(3)]
                for a in range(3)]  # fmt: skip
    np.testing.assert_allclose(class_bandwidth(V), expected, rtol=1e-12, atol=1e-16)


def test_bad_input() -> None:
    with pytest.raises(PerceptionError, match=r"depth_factor must be > 0, got 0\.0"):
        depth_sigma(1.0, 0.0)
    with pytest.raises(PerceptionError, match=r"depth_factor must be > 0, got \-5\.0"):
        depth_sigma(1.0, -5.0)
    with pytest.raises(PerceptionError, match=r"rho must be finite, got "):
        depth_sigma(np.nan, 100.0)
    with pytest.raises(PerceptionError, match=r"rho\[1\] must be finite, got "):
        depth_sigma([1.0, np.inf], 100.0)
    with pytest.raises(PerceptionError, match=r"rho must be > 0, got 0\.0"):
        disparity(0.0, 500.0, 0.1)
    with pytest.raises(PerceptionError, match=r"points must have shape.*\(3,\)"):
        perception_depth([1.0, 2.0], [0, 0, 0], [0, 0, 1])
    with pytest.raises(PerceptionError, match=r"viewing_direction must be non\-zero, got \[0\.0,"):
        perception_depth([1.0, 2.0, 3.0], [0, 0, 0], [0, 0, 0])
    with pytest.raises(PerceptionError, match=r"\(k, 3\)"):
        class_bandwidth(np.zeros((1, 3)))
    rig = StereoRig.default()
    with pytest.raises(PerceptionError, match=r"uv_left\[0, 0\] must be finite,.*nan"):
        triangulation_covariance(rig, [[np.nan, 1.0]], [[1.0, 1.0]])
    with pytest.raises(PerceptionError, match=r"pixel_sigma must be > 0, got 0\.0"):
        triangulation_covariance(rig, [[330.0, 240.0]], [[320.0, 240.0]], pixel_sigma=0.0)
