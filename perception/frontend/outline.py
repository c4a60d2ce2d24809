"""An object's stereo disparity from the outlines of its two masks, and the disparity error model.

The centroids of an object's left and right masks are not the images of one point when the two
eyes see different parts of it (a handle or a frame hides an edge in one eye, a door's side face
shows in one eye only), and a flat-shaded face gives dense matching nothing to hold on to.  The
outline does: on a rectified pair, the left end of the mask on a row of the left image and the
left end on the same row of the right image are the images of one edge point, and so are the
right ends.  :func:`outline_disparity` takes the disparities of these end points over every row
both masks cover (in the rectified frame of the rig, so any calibrated rig works), trims the
rows whose ends an occluder moved, and gives their mean with its standard error.

What the outline does not see (an edge both eyes see differently, a silhouette of a rounded
object) is an error of the type: :class:`DisparityError` carries it per type (a bias and a
standard deviation, pixels), :func:`fit_disparity_errors` measures it from pairs whose true
disparity is known (a calibration scene for a user's rig; :class:`perception.mujoco.MujocoScene`
measures it on its renders).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._checks import integer, real_array, real_scalar, sequence
from ..errors import PerceptionError
from .detection import MAX_PIXEL_COORDINATE, Detection

__all__ = [
    "DISPARITY_ENDS_FRACTION",
    "DISPARITY_SD_PX",
    "DisparityError",
    "OutlineDisparity",
    "fit_disparity_errors",
    "outline_disparity",
]

#: Fewest rows both masks must cover for an outline disparity (else the centroids are used).
MIN_OUTLINE_ROWS = 3
#: Rows whose end-point disparity lies more than this many robust standard deviations from the
#: trimmed mean are taken as moved by an occluder and left out (three passes).
OUTLINE_TRIM_SIGMA = 2.5
#: Smallest robust standard deviation (pixels) of an end point's disparity used for the trim: the
#: ends of a mask are quantised to whole pixels in both images.
OUTLINE_SCALE_FLOOR_PX = 0.5
#: Neighbouring rows whose end points err alike (a mask edge wanders over a few rows): the
#: standard error of the mean counts one independent end point per this many rows.
OUTLINE_ROW_CORRELATION = 4.0
#: The disparity error of a type with no measured :class:`DisparityError`, pixels: what the
#: outline does not see, measured on rendered kitchens across doors, drawers, handles and knobs.
DISPARITY_SD_PX = 0.5
#: The fraction of an outline's end difference (:attr:`OutlineDisparity.ends_differ_px`) a type
#: with no measured :class:`DisparityError` takes as a standard deviation: an end one eye sees cut
#: by an occluder moves the disparity by half the difference (a slanted face differs as much,
#: unharmed, so this is the cautious end).
DISPARITY_ENDS_FRACTION = 0.5
#: Largest ``ends_fraction`` of a :class:`DisparityError`.
MAX_ENDS_FRACTION = 10.0
#: Largest bias or standard deviation of a :class:`DisparityError`, pixels.
MAX_DISPARITY_ERROR_PX = 1e3


@dataclass(frozen=True)
class DisparityError:
    """The disparity error of one type beyond the outline's own standard error, pixels.

    Parameters
    ----------
    bias_px : float
        Mean measured minus true disparity; :func:`perception.stereo_percepts` subtracts it.
    sd_px : float
        Standard deviation about the bias, added in quadrature to the outline's standard error.
    ends_fraction : float
        Times the outline's :attr:`~OutlineDisparity.ends_differ_px`, a standard deviation added
        in quadrature too: the error of a pair whose ends disagree (an end one eye sees cut).

    The disparity's variance is ``sd^2 + sd_px^2 + (ends_fraction * ends_differ_px)^2``.
    """

    bias_px: float = 0.0
    sd_px: float = DISPARITY_SD_PX
    ends_fraction: float = DISPARITY_ENDS_FRACTION

    def __post_init__(self) -> None:
        m = MAX_DISPARITY_ERROR_PX
        object.__setattr__(self, "bias_px", real_scalar("bias_px", self.bias_px, minimum=-m, maximum=m))
        object.__setattr__(self, "sd_px", real_scalar("sd_px", self.sd_px, minimum=0.0, maximum=m))
        object.__setattr__(self, "ends_fraction", real_scalar("ends_fraction", self.ends_fraction,
                                                              minimum=0.0, maximum=MAX_ENDS_FRACTION))

    def variance(self, outline: OutlineDisparity) -> float:
        """The variance (pixels squared) of ``outline``'s disparity: its own standard error, this
        type's ``sd_px`` and ``ends_fraction`` times its ends' difference, in quadrature."""
        return float(outline.sd ** 2 + self.sd_px ** 2 + (self.ends_fraction * outline.ends_differ_px) ** 2)


@dataclass(frozen=True)
class OutlineDisparity:
    """The result of :func:`outline_disparity`.

    Attributes
    ----------
    disparity : float
        Disparity (pixels, rectified frame) of the object at the rows both masks cover.
    sd : float
        Standard error of ``disparity`` from the spread of the rows kept.
    rows : int
        Rows both masks cover.
    kept_fraction : float
        Fraction of the rows' end points kept by the trim (the rest moved by an occluder).
    uv_right : (2,) float
        Pixel of the right image (distorted, as detected) at ``disparity`` from the left mask's
        centroid along its epipolar line: the left centroid's match.
    duv_right : (2,) float
        Derivative of ``uv_right`` with respect to ``disparity``.
    ends_differ_px : float
        Mean disparity of the kept left ends minus that of the right ends: a slanted face, or an
        end that one eye sees cut by an occluder (which ``sd`` does not see; see
        :class:`DisparityError`).  Less what a mask one eye draws wider all round explains: when
        its top and bottom rows lie ``dk`` rows outside the other's, ``2 dk``.
    """

    disparity: float
    sd: float
    rows: int
    kept_fraction: float
    uv_right: NDArray[np.float64]
    duv_right: NDArray[np.float64]
    ends_differ_px: float = 0.0


def _ends(mask: NDArray[np.bool_]) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Rows of ``mask`` with pixels and their left and right pixel edges (``u - 1/2``, ``u + 1/2``)."""
    rows = np.nonzero(mask.any(axis=1))[0]
    part = mask[rows]
    lo = np.argmax(part, axis=1).astype(np.float64) - 0.5
    hi = (mask.shape[1] - 1 - np.argmax(part[:, ::-1], axis=1)).astype(np.float64) + 0.5
    return rows.astype(np.float64), lo, hi


def _rectified(rig: Any, rect: Any, which: int, uv: NDArray[np.float64]) -> NDArray[np.float64]:
    """Pixels of the left (``which`` 0) or right camera in its rectified image."""
    xy = rig.normalized(uv, uv)[which]
    R, P = (rect.R1, rect.P1) if which == 0 else (rect.R2, rect.P2)
    h = np.column_stack([xy, np.ones(len(xy))]) @ (P[:, :3] @ R).T
    return h[:, :2] / h[:, 2:3]


def _unrectified_right(rig: Any, rect: Any, uv: NDArray[np.float64]) -> NDArray[np.float64]:
    """Right-image pixels (distorted) of points of the right rectified image."""
    import cv2

    P = rect.P2
    ray = np.column_stack([(uv[:, 0] - P[0, 2]) / P[0, 0], (uv[:, 1] - P[1, 2]) / P[1, 1], np.ones(len(uv))])
    ray = ray @ rect.R2  # rectified -> right camera frame (R2 maps camera to rectified)
    out, _ = cv2.projectPoints(ray.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), rig.K2, rig.D2)
    return np.asarray(out, dtype=np.float64).reshape(-1, 2)


def outline_disparity(rig: Any, left: Detection, right: Detection, rectification: Any = None, *,
                      at: ArrayLike | None = None) -> OutlineDisparity | None:
    """An object's disparity from the end points of its left and right masks, row by row.

    Both masks' end points (the outer edges of each row's first and last pixel) are mapped into
    the rig's rectified images (:meth:`~perception.StereoRig.rectify`) and binned by rectified
    row; on every row both cover, the left ends give one disparity and the right ends another.
    Rows an occluder moved are trimmed (:data:`OUTLINE_TRIM_SIGMA` robust standard deviations,
    three passes); the disparity is that of the mean depth of the rest (their harmonic mean: a
    slanted face's depth, not its disparity, is linear across it) and ``sd`` its standard error,
    one independent end point per :data:`OUTLINE_ROW_CORRELATION` rows.

    Parameters
    ----------
    rig : StereoRig
    left, right : Detection
        A matched pair (:func:`perception.match_stereo`) with masks.
    rectification : Rectification, optional
        ``rig.rectify()``, when several pairs of one rig are measured.
    at : (2,) float, optional
        The left pixel whose match ``uv_right`` gives; default the left mask's centroid.

    Returns
    -------
    OutlineDisparity or None
        None when a mask is missing or the masks share fewer than :data:`MIN_OUTLINE_ROWS` rows.

    Raises
    ------
    PerceptionError
        ``rig`` not a StereoRig, ``left`` or ``right`` not a Detection.
    """
    from ..head.stereo import Rectification, as_stereo_rig

    rig = as_stereo_rig(rig)
    for name, det in (("left", left), ("right", right)):
        if not isinstance(det, Detection):
            raise PerceptionError(f"{name} must be a perception.Detection, got {type(det).__name__}")
    if left.mask is None or right.mask is None:
        return None
    if rectification is not None and not isinstance(rectification, Rectification):
        raise PerceptionError(f"rectification must be a perception.Rectification (rig.rectify()) or None, "
                              f"got {type(rectification).__name__}")
    rect = rig.rectify() if rectification is None else rectification
    per_eye = []
    for which, det in ((0, left), (1, right)):
        rows, lo, hi = _ends(det.mask)  # type: ignore[arg-type]  # checked above
        if rows.size == 0:
            return None
        ends = np.vstack([np.column_stack([lo, rows]), np.column_stack([hi, rows])])
        pts = _rectified(rig, rect, which, ends)
        n = rows.size
        bins = np.rint(pts[:, 1]).astype(np.int64)
        first = np.full(bins.max() - bins.min() + 1, np.inf)
        last = np.full_like(first, -np.inf)
        b0 = bins.min()
        np.minimum.at(first, bins[:n] - b0, pts[:n, 0])
        np.maximum.at(last, bins[n:] - b0, pts[n:, 0])
        per_eye.append((b0, first, last))
    (b_l, first_l, last_l), (b_r, first_r, last_r) = per_eye
    lo_bin, hi_bin = max(b_l, b_r), min(b_l + first_l.size, b_r + first_r.size)
    if hi_bin - lo_bin < MIN_OUTLINE_ROWS:
        return None
    sl, sr = slice(lo_bin - b_l, hi_bin - b_l), slice(lo_bin - b_r, hi_bin - b_r)
    with np.errstate(invalid="ignore"):  # a row binned in one eye only: inf - inf
        d = np.concatenate([first_l[sl] - first_r[sr], last_l[sl] - last_r[sr]])
    is_left_end = np.arange(d.size) < d.size // 2
    finite = np.isfinite(d)
    d, is_left_end = d[finite], is_left_end[finite]
    n_rows = int(d.size // 2)
    if n_rows < MIN_OUTLINE_ROWS:
        return None
    keep = np.ones(d.size, dtype=bool)
    centre = float(np.median(d))
    for _ in range(3):
        scale = max(OUTLINE_SCALE_FLOOR_PX, 1.4826 * float(np.median(np.abs(d[keep] - centre))))
        keep = np.abs(d - centre) <= OUTLINE_TRIM_SIGMA * scale
        centre = float(np.mean(d[keep]))
    kept = d[keep]
    if np.all(kept > 0):  # the depth, not the disparity, is what is linear across a slanted face
        centre = float(kept.size / np.sum(1.0 / kept))
    spread = max(float(np.std(kept)), OUTLINE_SCALE_FLOOR_PX / np.sqrt(3.0))
    standard_error = spread / np.sqrt(max(1.0, kept.size / OUTLINE_ROW_CORRELATION))
    left_kept, right_kept = keep & is_left_end, keep & ~is_left_end
    ends_differ = (float(np.mean(d[left_kept]) - np.mean(d[right_kept]))
                   if left_kept.any() and right_kept.any() else 0.0)
    # a mask one eye draws wider all round (a detector's edge) moves its top and bottom rows apart
    # as its left and right ends: 2 dk of the ends' difference that is no occluder's
    top, bottom = b_l - b_r, (b_l + first_l.size) - (b_r + first_r.size)
    dk = min(-top, bottom) if top < 0 < bottom else (-min(top, -bottom) if bottom < 0 < top else 0)
    ends_differ += 2.0 * dk
    # an end one eye sees cut by an occluder (a cabinet's side, the next door) moves every row's end
    # alike, which the trim cannot see: DisparityError.ends_fraction turns the ends' difference
    # into the error it may add
    if at is None:
        anchor = np.asarray(left.centroid_uv, dtype=np.float64)
    else:
        anchor = real_array("at", at, shape=(2,))
        if np.any(np.abs(anchor) > MAX_PIXEL_COORDINATE):
            raise PerceptionError(f"at = {anchor.tolist()} must be at most {MAX_PIXEL_COORDINATE:g} px")
    c = _rectified(rig, rect, 0, anchor[None, :])[0]
    step = 0.5
    pair = _unrectified_right(rig, rect, np.array([[c[0] - centre, c[1]], [c[0] - centre - step, c[1]],
                                                   [c[0] - centre + step, c[1]]]))
    return OutlineDisparity(centre, float(standard_error), n_rows, float(keep.mean()), pair[0],
                            (pair[1] - pair[2]) / (2.0 * step), ends_differ)


def fit_disparity_errors(types: Sequence[str], measured_px: ArrayLike, true_px: ArrayLike,
                         known_sd_px: ArrayLike | None = None, *, ends_differ_px: ArrayLike | None = None,
                         min_pairs: int = 5) -> dict[str, DisparityError]:
    """Per type, the :class:`DisparityError` of measured against true disparities.

    For a user's rig: match and measure pairs (:func:`outline_disparity`) in a scene whose object
    positions are known (their true disparity is the rig's focal length times its baseline over
    the depth of the surface seen), and pass the result to :func:`perception.stereo_percepts`.

    Parameters
    ----------
    types : sequence of str
        Each pair's type.
    measured_px, true_px : (n,) float
        Measured and true disparities, pixels.
    known_sd_px : (n,) float, optional
        Each pair's standard deviation already modelled (the outline's ``sd``); its mean square is
        taken off the measured variance so that it is not counted twice.
    ends_differ_px : (n,) float, optional
        Each pair's :attr:`OutlineDisparity.ends_differ_px`: then ``sd_px`` and ``ends_fraction``
        are fitted together by maximum likelihood (pairs whose ends disagree err more); without
        it ``ends_fraction`` is 0 and ``sd_px`` covers every pair alike.
    min_pairs : int
        Fewest pairs of a type to fit it; types with fewer are left out.

    Returns
    -------
    dict of str to DisparityError
        ``bias_px`` the median error; without ``ends_differ_px``, ``sd_px`` the root mean square
        about it (tails included: a model that covers every pair the front end keeps) less the
        known part, at least 0, and ``ends_fraction`` 0; with it, both by maximum likelihood.

    Raises
    ------
    PerceptionError
        Lengths that differ, values that are not finite, ``min_pairs`` < 1.
    """
    names = [str(t) for t in sequence("types", types, str)]
    if not names:
        raise PerceptionError("types must name at least one pair's type, got an empty sequence")
    m = real_array("measured_px", measured_px, shape=(None,))
    t = real_array("true_px", true_px, shape=(None,))
    known = (np.zeros(len(names)) if known_sd_px is None
             else real_array("known_sd_px", known_sd_px, shape=(None,)))
    ends = None if ends_differ_px is None else real_array("ends_differ_px", ends_differ_px, shape=(None,))
    for name, arr in (("measured_px", m), ("true_px", t), ("known_sd_px", known), ("ends_differ_px", ends)):
        if arr is None:
            continue
        if arr.size != len(names):
            raise PerceptionError(f"{name} has {arr.size} values but types has {len(names)}: one per pair")
    if np.any(known < 0):
        i = int(np.argmax(known < 0))
        raise PerceptionError(f"known_sd_px[{i}] must be >= 0, got {known[i]!r}")
    k = integer("min_pairs", min_pairs, minimum=1)
    err = m - t
    out: dict[str, DisparityError] = {}
    for typ in sorted(set(names)):
        sel = np.array([n == typ for n in names])
        if int(sel.sum()) < k:
            continue
        bias = float(np.median(err[sel]))
        if ends is None:
            var = float(np.mean(np.square(err[sel] - bias)) - np.mean(np.square(known[sel])))
            out[typ] = DisparityError(bias, float(np.sqrt(max(var, 0.0))), 0.0)
        else:
            out[typ] = DisparityError(bias, *_fit_spread(err[sel] - bias, known[sel] ** 2, ends[sel]))
    return out


def disparity_errors(value: object, types: set[str]) -> dict[str, DisparityError]:
    """Per type the :class:`DisparityError` of ``disparity_error`` (a mapping, one for every type,
    a standard deviation in pixels, or None: :data:`DISPARITY_SD_PX` for every type)."""
    def one(name: str, v: object) -> DisparityError:
        if isinstance(v, DisparityError):
            return v
        try:
            return DisparityError(0.0, real_scalar(name, v, minimum=0.0, maximum=MAX_DISPARITY_ERROR_PX))
        except PerceptionError as exc:
            raise type(exc)(f"{name} must be a DisparityError or a standard deviation in pixels: "
                            f"{exc}") from exc

    if value is None:
        return dict.fromkeys(types, DisparityError())
    if isinstance(value, Mapping):
        given = {str(t): one(f"disparity_error[{t!r}]", v) for t, v in value.items()}
        return {t: given.get(t, DisparityError()) for t in types} | given
    return dict.fromkeys(types, one("disparity_error", value))


def _mean_chi2(z2: NDArray[np.float64], scale: float, var: NDArray[np.float64],
               extra: NDArray[np.float64]) -> float:
    return float(np.mean(z2 / (var + extra * scale ** 2)))


def _solve_spread(z2: NDArray[np.float64], var: NDArray[np.float64], extra: NDArray[np.float64]) -> float:
    """The spread ``s`` (>= 0) at which the squared residuals ``z2`` over their variances
    ``var + extra s^2`` have mean 1, a chi-square of one degree's (bisection; 0 when they are
    already as small)."""
    if z2.size == 0 or _mean_chi2(z2, 0.0, var, extra) <= 1.0:
        return 0.0
    lo, hi = 0.0, 1.0
    while _mean_chi2(z2, hi, var, extra) > 1.0 and hi < MAX_DISPARITY_ERROR_PX:
        lo, hi = hi, 2.0 * hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _mean_chi2(z2, mid, var, extra) > 1.0 else (lo, mid)
    return hi


def _fit_spread(res: NDArray[np.float64], own_var: NDArray[np.float64], ends: NDArray[np.float64] | None
                ) -> tuple[float, float]:
    """Gaussian maximum likelihood of ``res ~ N(0, own_var + s^2 + (c ends)^2)``: ``(s, c)``, ``c``
    0 without ``ends`` (bounded: ``s`` to :data:`MAX_DISPARITY_ERROR_PX`, ``c`` to
    :data:`MAX_ENDS_FRACTION`)."""
    from scipy.optimize import minimize

    r2 = res ** 2
    e2 = np.zeros_like(res) if ends is None else ends ** 2
    floor = float(np.min(own_var)) if own_var.size and np.min(own_var) > 0 else 1.0 / MAX_DISPARITY_ERROR_PX

    def nll(x: NDArray[np.float64]) -> float:
        v = np.maximum(own_var + x[0] ** 2 + x[1] ** 2 * e2, floor)
        return float(np.sum(np.log(v) + r2 / v))

    start = np.array([float(np.sqrt(np.mean(r2))), 0.0 if ends is None else DISPARITY_ENDS_FRACTION])
    bounds = [(0.0, MAX_DISPARITY_ERROR_PX), (0.0, 0.0 if ends is None else MAX_ENDS_FRACTION)]
    best = min((minimize(nll, x0, method="L-BFGS-B", bounds=bounds) for x0 in (start, np.zeros(2))),
               key=lambda r: r.fun)
    return float(best.x[0]), float(best.x[1])


def split_spread(group: NDArray[np.int64], res: NDArray[np.float64], own_sd: NDArray[np.float64],
                  ends: NDArray[np.float64], ends_fraction: float = DISPARITY_ENDS_FRACTION
                  ) -> tuple[float, float]:
    """The error model of residuals ``res`` (one per view; ``group`` the object and scan each
    belongs to, ``own_sd`` its outline's standard error, ``ends`` its ends' difference):
    ``res = b_group + e``, ``e ~ N(0, own_sd^2 + (ends_fraction ends)^2 + s^2)``, ``b ~ N(0,
    t^2)``.  Returns ``(s, t)``: the total ``sqrt(s^2 + t^2)`` from all views, then ``s`` from
    each view's residual about its object's weighted mean, ``t`` the rest, each by
    :func:`_solve_spread`; with no object seen twice all of it is taken as shared (``s`` 0), the
    cautious side for fusing views."""
    v = own_sd ** 2 + (ends_fraction * ends) ** 2
    total = _solve_spread(res ** 2, v, np.ones_like(res))
    _, inv, count = np.unique(group, return_inverse=True, return_counts=True)
    multi = count[inv] > 1
    if not multi.any():
        return 0.0, total
    w = 1.0 / (v + total ** 2)
    mean = np.bincount(inv, w * res) / np.bincount(inv, w)
    share = w / np.bincount(inv, w)[inv]  # a view's weight in its object's mean
    within = (res - mean[inv])[multi]
    # var(res - mean) = (v + s^2) (1 - share) for views independent but for the shared part
    s = min(_solve_spread(within ** 2, (v * (1.0 - share))[multi], (1.0 - share)[multi]), total)
    return s, float(np.sqrt(total ** 2 - s ** 2))
