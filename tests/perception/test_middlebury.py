"""The depth-error model on real pixels (Middlebury motorcycle, bundled with scikit-image)."""

from __future__ import annotations

import numpy as np
import pytest

from perception import MissingExtraError, PerceptionError
from perception.middlebury import (
    depth_error_table,
    depth_from_disparity,
    fit_depth_factor,
    load_motorcycle,
    sgbm_disparity,
)

try:
    DATA = load_motorcycle()
except MissingExtraError:  # the optional data package is genuinely absent
    DATA = None

needs_data = pytest.mark.skipif(DATA is None, reason="scikit-image motorcycle data not available")


def test_depth_from_disparity_calibration() -> None:
    # Z = f b / (d + doffs) with f = 994.978 px, b = 0.193001 m, doffs = 31.086 px
    assert depth_from_disparity(50.0) == pytest.approx(994.978 * 0.193001 / 81.086, rel=1e-12)
    expected = [994.978 * 0.193001 / 31.086, 994.978 * 0.193001 / 41.086]
    np.testing.assert_allclose(depth_from_disparity(np.array([0.0, 10.0])), expected, rtol=1e-12)


def test_fit_depth_factor_is_least_squares() -> None:
    z = np.array([1.0, 2.0, 3.0, 4.0])
    s = np.array([0.0011, 0.0039, 0.0092, 0.0158])
    # independent: lstsq for a in s = a z^2
    a = np.linalg.lstsq((z**2)[:, None], s, rcond=None)[0][0]
    assert fit_depth_factor(z, s) == pytest.approx(1.0 / a, rel=1e-12)


@needs_data
def test_table_on_real_pixels() -> None:
    left, right, gt = DATA
    assert left.shape[:2] == right.shape[:2] == gt.shape
    table = depth_error_table(n_bins=6)
    assert len(table.rows) == 6
    # recompute the statistics independently from the disparity maps
    est = sgbm_disparity(left, right)
    valid = np.isfinite(gt) & np.isfinite(est)
    assert table.n_pixels == int(valid.sum())
    assert sum(r.count for r in table.rows) == table.n_pixels
    fb = 994.978 * 0.193001
    z_true = fb / (gt[valid].astype(float) + 31.086)
    err = fb / (est[valid] + 31.086) - z_true
    last = table.rows[-1]
    in_bin = (z_true >= last.depth_min) & (z_true <= last.depth_max)
    e = err[in_bin]
    assert last.count == int(in_bin.sum())
    assert last.median_error == pytest.approx(float(np.median(e)), abs=1e-12)
    assert last.robust_std == pytest.approx(1.4826 * float(np.median(np.abs(e - np.median(e)))), rel=1e-9)
    dd = est[valid] - gt[valid]
    assert table.disparity_error_std == pytest.approx(1.4826 * float(np.median(np.abs(dd - np.median(dd)))))
    # SGBM works on these pixels: sub-pixel disparity error, most pixels valid
    assert abs(table.disparity_error_median) < 0.5 and table.disparity_error_std < 1.0
    assert table.valid_fraction > 0.6
    # eq. 6 on real pixels: the spread grows with depth, and the fitted factor agrees with the
    # disparity-noise prediction sigma_Z = Z^2 sigma_d / (f b), i.e. depth_factor = f b / sigma_d
    stds = [r.robust_std for r in table.rows]
    assert stds[-1] > 2 * stds[0]
    assert table.depth_factor == pytest.approx(fb / table.disparity_error_std, rel=0.3)
    assert "| true depth (m) |" in table.to_markdown()


@needs_data
def test_subsampling_needs_rng() -> None:
    with pytest.raises(PerceptionError, match="rng"):
        depth_error_table(max_pixels=1000)
    t = depth_error_table(np.random.default_rng(0), max_pixels=5000, n_bins=4)
    assert t.n_pixels == 5000
