"""The depth-error model (eq. 6) on real pixels: the Middlebury 2014 motorcycle pair.

``skimage.data.stereo_motorcycle()`` ships the quarter-size pair with its ground-truth
disparity (bundled with scikit-image, no download). With the calibration
``f = 994.978 px``, ``b = 193.001 mm``, ``doffs = 31.086 px`` the depth is
``Z = f b / (d + doffs)``. :func:`depth_error_table` runs ``cv2.StereoSGBM``, compares it
with the ground truth, and fits ``sigma = Z^2 / depth_factor`` to the robust spread of the
depth error per depth bin. scikit-image is an optional dependency (the ``test`` extra).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .errors import MissingExtraError, PerceptionError
from .head.uncertainty import depth_sigma

FOCAL_PX = 994.978
BASELINE_M = 0.193001
DOFFS_PX = 31.086
MAD_TO_STD = 1.4826


@dataclass(frozen=True)
class DepthErrorRow:
    """Depth-error statistics of one bin of true depth (metres)."""

    depth_min: float
    depth_max: float
    depth_median: float
    count: int
    median_error: float
    robust_std: float
    model_sigma: float


@dataclass(frozen=True)
class DepthErrorTable:
    """Result of :func:`depth_error_table`.

    Attributes
    ----------
    rows : tuple of DepthErrorRow
        One row per depth bin, nearest first.
    depth_factor : float
        Least-squares fit of ``robust_std = depth_median^2 / depth_factor`` (eq. 6), 1/m.
    disparity_error_median, disparity_error_std : float
        Median and robust (MAD) standard deviation of the disparity error, pixels.
    valid_fraction : float
        Fraction of pixels with both a ground truth and an SGBM disparity.
    n_pixels : int
        Number of compared pixels.
    """

    rows: tuple[DepthErrorRow, ...]
    depth_factor: float
    disparity_error_median: float
    disparity_error_std: float
    valid_fraction: float
    n_pixels: int

    def to_markdown(self) -> str:
        """The table as Markdown."""
        lines = [
            "| true depth (m) | pixels | median error (mm) | robust std (mm) | Z^2/depth_factor (mm) |",
            "|---|---|---|---|---|",
        ]
        for r in self.rows:
            lines.append(
                f"| {r.depth_min:.2f}-{r.depth_max:.2f} | {r.count} | {1e3 * r.median_error:+.1f} "
                f"| {1e3 * r.robust_std:.1f} | {1e3 * r.model_sigma:.1f} |"
            )
        return "\n".join(lines)


def load_motorcycle() -> tuple[NDArray[np.uint8], NDArray[np.uint8], NDArray[np.float32]]:
    """The motorcycle pair ``(left, right, disparity)`` from scikit-image (RGB, RGB, float32).

    Raises
    ------
    MissingExtraError
        scikit-image is not installed or cannot provide the data.
    """
    try:
        from skimage import data
    except ImportError as exc:
        raise MissingExtraError("scikit-image is not installed: pip install scikit-image") from exc
    try:
        left, right, disp = data.stereo_motorcycle()
    except Exception as exc:  # any failure to fetch the optional data set (e.g. no network)
        raise MissingExtraError(f"skimage.data.stereo_motorcycle() failed: {exc}") from exc
    return left, right, disp


def depth_from_disparity(disparity: NDArray[np.floating] | float) -> NDArray[np.float64] | float:
    """``Z = f b / (d + doffs)`` in metres for the motorcycle calibration."""
    d = np.asarray(disparity, dtype=np.float64)
    z = FOCAL_PX * BASELINE_M / (d + DOFFS_PX)
    return float(z) if z.ndim == 0 else z


def sgbm_disparity(
    left: NDArray[np.uint8], right: NDArray[np.uint8], *, num_disparities: int = 64, block_size: int = 5
) -> NDArray[np.float64]:
    """Semi-global block matching (``cv2.StereoSGBM``, 3-way) disparity; NaN where invalid.

    Parameters
    ----------
    left, right : (h, w, 3) or (h, w) uint8
        RGB or grey images of the same shape.
    num_disparities : int
        Multiple of 16.
    block_size : int
        Odd matching block size.

    Returns
    -------
    (h, w) float
        Disparity in pixels (sub-pixel, 1/16 steps).
    """
    import cv2
    if left.shape != right.shape or left.ndim not in (2, 3):
        raise PerceptionError(f"left and right must be images of one shape, got {left.shape} and "
                              f"{right.shape}")
    gl = cv2.cvtColor(left, cv2.COLOR_RGB2GRAY) if left.ndim == 3 else left
    gr = cv2.cvtColor(right, cv2.COLOR_RGB2GRAY) if right.ndim == 3 else right
    channels = 1
    matcher = cv2.StereoSGBM.create(
        minDisparity=0,
        numDisparities=int(num_disparities),
        blockSize=int(block_size),
        P1=8 * channels * block_size**2,
        P2=32 * channels * block_size**2,
        disp12MaxDiff=1,
        uniquenessRatio=10,
        speckleWindowSize=100,
        speckleRange=2,
        mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY,
    )
    raw = matcher.compute(gl, gr).astype(np.float64) / 16.0
    raw[raw < 0] = np.nan
    return raw


def fit_depth_factor(depth: NDArray[np.float64], sigma: NDArray[np.float64]) -> float:
    """Least squares ``sigma ~ depth^2 / depth_factor``: ``1 / depth_factor = sum s Z^2 / sum Z^4``."""
    z2 = np.asarray(depth, dtype=np.float64) ** 2
    return float(np.sum(z2 * z2) / np.sum(np.asarray(sigma, dtype=np.float64) * z2))


def _robust_std(x: NDArray[np.float64]) -> float:
    return float(MAD_TO_STD * np.median(np.abs(x - np.median(x))))


def depth_error_table(
    rng: np.random.Generator | None = None,
    *,
    n_bins: int = 8,
    num_disparities: int = 64,
    block_size: int = 5,
    max_pixels: int | None = None,
) -> DepthErrorTable:
    """Depth error of SGBM on the motorcycle pair, binned by true depth (equal-count bins).

    Parameters
    ----------
    rng : numpy.random.Generator, optional
        Used only to subsample ``max_pixels`` compared pixels.
    n_bins : int
        Number of depth bins (quantiles of the true depth).
    num_disparities, block_size : int
        SGBM parameters.
    max_pixels : int, optional
        Compare at most this many pixels (random subset; needs ``rng``).

    Raises
    ------
    MissingExtraError
        The data set is not available.
    """
    left, right, gt = load_motorcycle()
    est = sgbm_disparity(left, right, num_disparities=num_disparities, block_size=block_size)
    valid = np.isfinite(gt) & np.isfinite(est)
    d_true = gt[valid].astype(np.float64)
    d_est = est[valid]
    if max_pixels is not None and d_true.size > max_pixels:
        if rng is None:
            raise PerceptionError("max_pixels needs an rng to draw the subset")
        keep = rng.choice(d_true.size, int(max_pixels), replace=False)
        d_true, d_est = d_true[keep], d_est[keep]
    z_true = np.asarray(depth_from_disparity(d_true))
    err = np.asarray(depth_from_disparity(d_est)) - z_true
    edges = np.quantile(z_true, np.linspace(0.0, 1.0, int(n_bins) + 1))
    which = np.clip(np.searchsorted(edges, z_true, side="right") - 1, 0, int(n_bins) - 1)
    meds, stds, rows = [], [], []
    for k in range(int(n_bins)):
        m = which == k
        e = err[m]
        meds.append(float(np.median(z_true[m])))
        stds.append(_robust_std(e))
        stats = (meds[-1], int(m.sum()), float(np.median(e)), stds[-1])
        rows.append((float(edges[k]), float(edges[k + 1]), *stats))
    df = fit_depth_factor(np.array(meds), np.array(stds))
    table_rows = tuple(DepthErrorRow(*r, model_sigma=float(depth_sigma(r[2], df))) for r in rows)
    derr = d_est - d_true
    return DepthErrorTable(
        rows=table_rows,
        depth_factor=df,
        disparity_error_median=float(np.median(derr)),
        disparity_error_std=_robust_std(derr),
        valid_fraction=float(valid.mean()),
        n_pixels=int(d_true.size),
    )


def __getattr__(name: str) -> type[PerceptionError]:
    """``MissingDataError``, 0.1's name of :class:`~perception.errors.MissingExtraError` here,
    deprecated."""
    from . import errors

    return errors._deprecated(__name__, name, {"MissingDataError": MissingExtraError})
