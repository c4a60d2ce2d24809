"""Colour segmentation and region features: step 2 of :mod:`perception.recognition` before the
classifier.

:func:`region_features` segments a BGR image by the HSV boxes of :data:`COLOR_RANGES`
(``cv2.inRange``), splits the masks into connected regions and describes every region by the
features :data:`FEATURE_NAMES` (from the eigen-decomposition of its pixel covariance, its area,
fill ratio and mean colour).  Every name here is also importable from
:mod:`perception.recognition`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._checks import integer, real_array
from ..errors import PerceptionError
from ..simulation.render import MAX_RENDER_PIXELS
from ..tolerances import EIGENVALUE_FLOOR

__all__ = ["COLOR_RANGES", "FEATURE_NAMES", "ColorRange", "region_features"]


@dataclass(frozen=True)
class ColorRange:
    """An HSV box for ``cv2.inRange`` (OpenCV HSV: H in [0, 180), S and V in [0, 255])."""

    lower: tuple[int, int, int]
    upper: tuple[int, int, int]

    def __post_init__(self) -> None:
        lo = real_array("lower", self.lower, (3,))
        hi = real_array("upper", self.upper, (3,))
        for name, arr in (("lower", lo), ("upper", hi)):
            if np.any((arr < 0) | (arr > 255) | (arr != np.round(arr))):
                raise PerceptionError(f"{name} must hold integers in [0, 255], got {arr.tolist()}")
        if np.any(lo > hi):
            raise PerceptionError(f"lower {lo.tolist()} must not exceed upper {hi.tolist()}")


#: Segmentation colours: brown wood (doors, drawers) and bright low-saturation metal (handles).
COLOR_RANGES: Mapping[str, ColorRange] = {
    "wood": ColorRange((3, 110, 40), (25, 255, 255)),
    "metal": ColorRange((0, 0, 110), (180, 50, 255)),
}

_CLOSE_KERNEL = np.ones((3, 3), dtype=np.uint8)
_COS_HUE = np.cos(np.arange(256) * (np.pi / 90.0)).astype(np.float32).reshape(1, 256)
_SIN_HUE = np.sin(np.arange(256) * (np.pi / 90.0)).astype(np.float32).reshape(1, 256)

#: Names of the region features, in order.
FEATURE_NAMES: tuple[str, ...] = (
    "log_area",
    "log_elongation",
    "horizontalness",
    "fill_ratio",
    "chroma_a",
    "chroma_b",
    "value",
)

def _check_image(name: str, image: Any) -> NDArray[np.uint8]:
    if not isinstance(image, np.ndarray):
        raise PerceptionError(f"{name} must be a numpy array, got {type(image).__name__}")
    if image.ndim != 3 or image.shape[2] != 3:
        raise PerceptionError(f"{name} must have shape (height, width, 3) (BGR), got shape {image.shape}")
    if image.dtype != np.uint8:
        raise PerceptionError(f"{name} must have dtype uint8, got {image.dtype} (shape {image.shape})")
    if image.shape[0] * image.shape[1] > MAX_RENDER_PIXELS or 0 in image.shape:
        raise PerceptionError(
            f"{name} must have between 1 and {MAX_RENDER_PIXELS} pixels, got shape {image.shape}"
        )
    return image


def region_features(
    image: NDArray[np.uint8], *, color_ranges: Mapping[str, ColorRange] = COLOR_RANGES, min_area: int = 12
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Segment by colour and describe every connected region.

    Features (:data:`FEATURE_NAMES`), from the region's pixel covariance with eigenvalues
    ``l1 >= l2`` and major axis angle ``theta``: ``log(area)``, ``0.5 log(l1 / l2)`` (log
    elongation), ``|cos theta|`` (1 for a horizontal major axis), the fill ratio
    ``area / (12 sqrt(l1 l2))`` (1 for a solid rectangle), the mean chroma
    ``S cos(H), S sin(H)`` (S in [0, 1], H as an angle) and the mean value V in [0, 1].

    Returns
    -------
    features : (r, 7) float
    centroids : (r, 2) float
        Pixel centroids (u, v).
    areas : (r,) float
    touches_border : (r,) bool
        The region's bounding box touches the image border (it may be cut off).
    """
    feats, cents, areas, border, _ = _region_stats(image, color_ranges, min_area)
    return feats, cents, areas, border


def _region_stats(
    image: NDArray[np.uint8], color_ranges: Mapping[str, ColorRange], min_area: int
) -> tuple[
    NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64]
]:
    """:func:`region_features` plus each region's pixel covariance (r, 2, 2), px^2 (u, v)."""
    import cv2
    image = _check_image("image", image)
    min_area = integer("min_area", min_area, minimum=1, maximum=MAX_RENDER_PIXELS)
    if not isinstance(color_ranges, Mapping) or not all(
        isinstance(c, ColorRange) for c in color_ranges.values()
    ):
        raise PerceptionError(f"color_ranges must map names to ColorRange, got {color_ranges!r}")
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
    # per-pixel chroma (S cos H, S sin H) and value, in [0, 1], through hue look-up tables
    sat = hsv[:, :, 1].astype(np.float32) * np.float32(1.0 / 255.0)
    color = cv2.merge(
        [
            cv2.LUT(hsv[:, :, 0], _COS_HUE) * sat,
            cv2.LUT(hsv[:, :, 0], _SIN_HUE) * sat,
            hsv[:, :, 2].astype(np.float32) * np.float32(1.0 / 255.0),
        ]
    )
    feats, cents, areas, border, moments = [], [], [], [], []
    for rng_ in color_ranges.values():
        mask = cv2.inRange(hsv, np.array(rng_.lower, np.uint8), np.array(rng_.upper, np.uint8))
        mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, _CLOSE_KERNEL)
        n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        big = np.flatnonzero(stats[1:, cv2.CC_STAT_AREA] >= min_area) + 1
        if big.size == 0:
            continue
        # per region (on its bounding-box ROI): area, centroid, central second moments, mean
        # chroma and value
        stat = np.empty((9, big.size))
        for j, k in enumerate(big):
            x0, y0, w, h = (int(v) for v in stats[k, :4])
            roi = (labels[y0 : y0 + h, x0 : x0 + w] == k).astype(np.uint8)
            m = cv2.moments(roi, binaryImage=True)
            mean_color = cv2.mean(color[y0 : y0 + h, x0 : x0 + w], mask=roi)
            area = m["m00"]
            stat[:, j] = (
                area,
                x0 + m["m10"] / area,
                y0 + m["m01"] / area,
                m["mu20"] / area,
                m["mu02"] / area,
                m["mu11"] / area,
                *mean_color[:3],
            )
        count, mx, my = stat[0], stat[1], stat[2]
        # pixel covariance; + 1/12 for the extent of a unit pixel
        cxx = stat[3] + 1.0 / 12.0
        cyy = stat[4] + 1.0 / 12.0
        cxy = stat[5]
        half_tr = 0.5 * (cxx + cyy)
        root = np.sqrt(np.maximum((0.5 * (cxx - cyy)) ** 2 + cxy**2, 0.0))
        l1, l2 = half_tr + root, np.maximum(half_tr - root, EIGENVALUE_FLOOR)
        theta = 0.5 * np.arctan2(2.0 * cxy, cxx - cyy)
        feats.append(
            np.column_stack(
                [
                    np.log(count),
                    0.5 * np.log(l1 / l2),
                    np.abs(np.cos(theta)),
                    count / (12.0 * np.sqrt(l1 * l2)),
                    stat[6],
                    stat[7],
                    stat[8],
                ]
            )
        )
        cents.append(np.column_stack([mx, my]))
        areas.append(count)
        moments.append(np.stack([np.column_stack([cxx, cxy]), np.column_stack([cxy, cyy])], axis=1))
        st = stats[big]
        height, width = mask.shape
        border.append(
            (st[:, cv2.CC_STAT_LEFT] == 0)
            | (st[:, cv2.CC_STAT_TOP] == 0)
            | (st[:, cv2.CC_STAT_LEFT] + st[:, cv2.CC_STAT_WIDTH] >= width)
            | (st[:, cv2.CC_STAT_TOP] + st[:, cv2.CC_STAT_HEIGHT] >= height)
        )
    if not feats:
        return (
            np.zeros((0, len(FEATURE_NAMES))), np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=bool),
            np.zeros((0, 2, 2)),
        )
    return (
        np.concatenate(feats), np.concatenate(cents), np.concatenate(areas), np.concatenate(border),
        np.concatenate(moments),
    )
