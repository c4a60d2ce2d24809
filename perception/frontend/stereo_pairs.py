"""The stereo front end: left and right detections paired by type and the epipolar constraint
(:func:`match_stereo`) and triangulated to percepts (:func:`stereo_percepts`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment

from .._checks import _short, boolean, integer, name_string, real_scalar, sequence
from ..errors import PerceptionError
from ..head.chain import check_transform
from ..head.stereo import as_stereo_rig
from ..head.uncertainty import depth_sigma, triangulation_jacobian
from ..tolerances import NEAR_PLANE, PARALLEL_RAYS
from .detection import Detection
from .detection_percepts import (
    CENTRE_DEPTH_SIGMA,
    CentreOffset,
    DetectionPercepts,
    Dropped,
    _centre_offsets,
    _detections,
    _lateral,
    _percept,
    touches_border,
)
from .outline import DisparityError, disparity_errors, outline_disparity
from .percept import Percept

__all__ = ["DISPARITY_STD_PX", "DisparitySource", "StereoMatch", "match_stereo", "stereo_percepts"]

# --------------------------------------------------------------------------------------------
# pairing left and right detections
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class StereoMatch:
    """A left/right detection pair: indices into the two lists and the epipolar distance (px)."""

    left: int
    right: int
    epipolar_px: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "left", integer("left", self.left, minimum=0))
        object.__setattr__(self, "right", integer("right", self.right, minimum=0))
        epi = real_scalar("epipolar_px", self.epipolar_px, minimum=0.0)
        object.__setattr__(self, "epipolar_px", epi)


def _skew(t: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.array([[0.0, -t[2], t[1]], [t[2], 0.0, -t[0]], [-t[1], t[0], 0.0]])


def _undistort(
    uv: NDArray[np.float64], K: NDArray[np.float64], D: NDArray[np.float64]
) -> NDArray[np.float64]:
    import cv2
    if len(uv) == 0 or not np.any(D):
        return uv
    # float64 in, float64 out (OpenCV's stubs type the result as any real dtype)
    return cast(NDArray[np.float64], cv2.undistortPoints(uv.reshape(-1, 1, 2), K, D, P=K).reshape(-1, 2))


def match_stereo(
    rig: Any,
    left_dets: Sequence[Detection],
    right_dets: Sequence[Detection],
    max_epipolar_px: float = 2.0,
    *,
    max_log_area_ratio: float = 1.0,
    min_depth: float = 0.0,
) -> list[StereoMatch]:
    """Pair left and right detections of the same type.

    A pair is admissible when both have the same type, the right centroid lies within
    ``max_epipolar_px`` of the epipolar line ``F x_left`` (fundamental matrix
    ``F = K2^-T [T]x R K1^-1``, on undistorted pixels), the triangulated point lies in front
    of both cameras (for a rectified rig: positive disparity) and the areas differ by at most
    ``exp(max_log_area_ratio)``; a pair whose point would lie nearer than ``min_depth`` (metres,
    along the left optical axis) is not admissible either (two objects of one type side by side
    pair up along the epipolar line at a far larger disparity).  Among admissible pairs a
    one-to-one assignment minimising ``epipolar / max_epipolar_px + |log area ratio|`` is taken
    per type.

    Returns
    -------
    list of StereoMatch
    """
    as_stereo_rig(rig)
    max_epipolar_px = real_scalar("max_epipolar_px", max_epipolar_px, positive=True)
    max_log_area_ratio = real_scalar("max_log_area_ratio", max_log_area_ratio, minimum=0.0)
    min_depth = real_scalar("min_depth", min_depth, minimum=0.0, maximum=1e6)
    left_dets = sequence("left_dets", left_dets, Detection)
    right_dets = sequence("right_dets", right_dets, Detection)
    if not left_dets or not right_dets:
        return []
    K1, D1 = np.asarray(rig.K1, np.float64), np.asarray(rig.D1, np.float64)
    K2, D2 = np.asarray(rig.K2, np.float64), np.asarray(rig.D2, np.float64)
    R, T = np.asarray(rig.R, np.float64), np.asarray(rig.T, np.float64).reshape(3)
    F = np.linalg.inv(K2).T @ _skew(T) @ R @ np.linalg.inv(K1)
    uv_l = _undistort(np.array([d.centroid_uv for d in left_dets], dtype=np.float64), K1, D1)
    uv_r = _undistort(np.array([d.centroid_uv for d in right_dets], dtype=np.float64), K2, D2)
    hl = np.column_stack([uv_l, np.ones(len(uv_l))])
    hr = np.column_stack([uv_r, np.ones(len(uv_r))])
    lines = hl @ F.T  # (nl, 3): epipolar lines in the right image
    epi = np.abs(hr @ lines.T).T / np.hypot(lines[:, 0], lines[:, 1])[:, None]  # (nl, nr)
    area_l = np.array([d.area for d in left_dets])
    area_r = np.array([d.area for d in right_dets])
    log_ratio = np.abs(np.log(area_l[:, None] / area_r[None, :]))
    same = np.array([[a.type == b.type for b in right_dets] for a in left_dets])
    ok = same & (epi <= max_epipolar_px) & (log_ratio <= max_log_area_ratio)
    il, ir = np.nonzero(ok)
    if il.size:
        # depth in both cameras by linear triangulation on normalised rays (cheirality)
        xl = np.linalg.solve(K1, hl[il].T).T
        xr = np.linalg.solve(K2, hr[ir].T).T
        # X = a xl; R X + T = b xr -> a R xl - b xr = -T (least squares per pair)
        A = np.stack([(R @ xl.T).T, -xr], axis=2)  # (p, 3, 2)
        ata = np.einsum("pki,pkj->pij", A, A)
        atb = np.einsum("pki,k->pi", A, -T)
        det = ata[:, 0, 0] * ata[:, 1, 1] - ata[:, 0, 1] ** 2
        good = det > PARALLEL_RAYS
        a = np.where(good, (ata[:, 1, 1] * atb[:, 0] - ata[:, 0, 1] * atb[:, 1]) / np.where(good, det, 1), -1)
        b = np.where(good, (ata[:, 0, 0] * atb[:, 1] - ata[:, 0, 1] * atb[:, 0]) / np.where(good, det, 1), -1)
        front = (a > max(NEAR_PLANE, min_depth)) & (b > NEAR_PLANE)
        ok[il[~front], ir[~front]] = False
    cost = np.where(ok, epi / max_epipolar_px + log_ratio, np.inf)
    matches: list[StereoMatch] = []
    rows_all = np.flatnonzero(ok.any(axis=1))
    if rows_all.size == 0:
        return []
    big = 1e6
    finite = np.where(ok, cost, big)
    rows, cols = linear_sum_assignment(finite[rows_all])
    for r, c in zip(rows_all[rows], cols, strict=True):
        if ok[r, c]:
            matches.append(StereoMatch(left=int(r), right=int(c), epipolar_px=float(epi[r, c])))
    matches.sort(key=lambda m: m.left)
    return matches


#: Default disparity error of matched region centroids, pixels: ``1 / sqrt(12)``. Rendering
#: (and any camera) quantises a region's outline to whole pixels; each of the two edges that
#: bound the region along u is off by a uniform +-0.5 px error and moves the centroid by half
#: of it, so a centroid coordinate has variance ``2 (1/12) / 4 = 1/24`` per image when the
#: edges run along pixel rows or columns (less when slanted edges average it out), and the
#: disparity, independent left and right, ``1/12`` (measured: docs/design.md#defaults).
DISPARITY_STD_PX: float = float(1.0 / np.sqrt(12.0))


# ----------------------------------------------------------------------------------------------
# percepts from the pairs
# ----------------------------------------------------------------------------------------------
#: Nearest depth (m) a stereo pair may triangulate to: nearer than a robot's head ever is to
#: what it recognises, and where two same-typed objects side by side pair up wrongly.
MIN_STEREO_DEPTH = 0.3
#: The two images of one object must agree on its extent: box widths and heights within this
#: fraction (or :data:`EXTENT_PX`), else a part of it is hidden in one image (occluded, cut) and
#: the centroids' disparity is not the object's.
EXTENT_RTOL = 0.1
#: Absolute slack (pixels) of the extent comparison.
EXTENT_PX = 2.0


def extents_differ(a: Detection, b: Detection) -> str:
    """Why the boxes of a left/right pair disagree (empty when they agree)."""
    if a.box is None or b.box is None:
        return ""
    for k, name in ((0, "width"), (1, "height")):
        ea, eb = a.box[k + 2] - a.box[k] + 1.0, b.box[k + 2] - b.box[k] + 1.0
        if abs(ea - eb) > max(EXTENT_PX, EXTENT_RTOL * max(ea, eb)):
            return (f"its {name} is {ea:.0f} px in the left image and {eb:.0f} px in the right (more than "
                    f"{100 * EXTENT_RTOL:.0f} % apart): part of it is hidden in one of them")
    return ""


def stereo_percepts(
    left: Sequence[Detection],
    right: Sequence[Detection],
    rig: Any,
    ego_from_camera: ArrayLike,
    *,
    centre_offset: float | CentreOffset | Mapping[str, float | CentreOffset] | None = None,
    depth_factor: float | None = None,
    pixel_sigma: float | None = None,
    max_epipolar_px: float = 2.0,
    min_depth: float = MIN_STEREO_DEPTH,
    keep_cut_off: bool = False,
    disparity_from: DisparitySource | Mapping[str, DisparitySource] = "centroids",
    disparity_error: float | DisparityError | Mapping[str, float | DisparityError] | None = None,
) -> DetectionPercepts:
    """Percepts from detections in the two images of a stereo rig.

    Left and right detections are paired by type and the epipolar constraint
    (:func:`perception.match_stereo`). Each pair's disparity comes from its two centroids (by
    default) or from the outlines of its two masks (:func:`perception.outline_disparity`); the
    left centroid (outline: the middle of the left mask's extent) is triangulated at that
    disparity (:meth:`StereoRig.triangulate`) and moved along the viewing ray to the object's
    centre by its centre depth (module docstring). The covariance maps pixel errors through the
    triangulation Jacobian: the left centroid's own error ``pixel_sigma`` per coordinate; the
    disparity's error (outline: its standard error and the type's
    :class:`~perception.DisparityError` in quadrature; centroids: ``pixel_sigma`` in each image,
    independent); and the offset of the centroid from the image of the object's centre,
    :data:`CENTRE_OFFSET_SCALE` times the region's pixel spread, the same in both images and
    shared by the object's views (id :data:`~perception.OBJECT_VIEW`) with the centre depth's
    uncertainty.

    Parameters
    ----------
    left, right : sequence of Detection
        Detections in the left and the right image.
    rig : StereoRig
    ego_from_camera : (4, 4) float
        Left camera frame (OpenCV) to ego frame; :meth:`perception.KinematicChain.ego_from_camera`.
    centre_offset : CentreOffset, float, or mapping of str to CentreOffset or float, optional
        As for :func:`rgbd_percepts`, along the viewing ray; types without one are taken at
        their centroid with :data:`CENTRE_DEPTH_SIGMA` of uncertainty along the ray.
    depth_factor : float, optional
        The paper's eq. 6: each percept's ``sigma = rho**2 / depth_factor`` (``rho`` the depth
        along the left optical axis), which the paper's method reads.  Default: ``sigma`` is the
        standard deviation of the range under the covariance.
    pixel_sigma : float, optional
        Centroid error per image coordinate, pixels; default
        ``perception.recognition.DISPARITY_STD_PX / sqrt(2)`` (outline quantisation).
    max_epipolar_px : float
        Largest distance of a right centroid from the left one's epipolar line.
    min_depth : float
        Nearest depth (m) a pair may triangulate to; default :data:`MIN_STEREO_DEPTH`.
    keep_cut_off : bool
        Keep regions that touch the border of either image (their centre's offset then as
        uncertain as the region is wide).
    disparity_from : {"centroids", "outline"} or mapping of str to either
        ``"centroids"``: the centroids' difference, the paper's measurement; ``"outline"``: the
        masks' row ends (pairs without masks, sharing fewer than
        :data:`perception.frontend.outline.MIN_OUTLINE_ROWS` rows or with a disparity that is not
        positive fall back to the centroids), robust to an edge an occluder hides in one eye.
        A mapping chooses per type (types it does not name: ``"centroids"``), as
        :meth:`perception.mujoco.MujocoScene.default_stereo_offsets` measures which is better.
    disparity_error : DisparityError, float, or mapping of str to DisparityError or float, optional
        ``"outline"`` only: the outline disparity's error per type beyond its own standard
        error (a float: a standard deviation in pixels); measure it for your rig with
        :func:`perception.fit_disparity_errors`.  Default: :class:`~perception.DisparityError`'s
        defaults (:data:`perception.DISPARITY_SD_PX`, :data:`perception.DISPARITY_ENDS_FRACTION`
        of the ends' difference, no bias).

    Returns
    -------
    DetectionPercepts
        ``sources`` and ``dropped`` index the left detections.
    """
    rig = as_stereo_rig(rig)
    lefts = _detections("left", left)
    rights = _detections("right", right)
    T = check_transform("ego_from_camera", ego_from_camera)
    keep_cut_off = boolean("keep_cut_off", keep_cut_off)
    max_epipolar_px = real_scalar("max_epipolar_px", max_epipolar_px, positive=True, maximum=1e6)
    min_depth = real_scalar("min_depth", min_depth, minimum=0.0, maximum=1e6)
    if depth_factor is not None:
        depth_factor = real_scalar("depth_factor", depth_factor, positive=True, maximum=1e150)
    px = DISPARITY_STD_PX / np.sqrt(2.0) if pixel_sigma is None else real_scalar(
        "pixel_sigma", pixel_sigma, positive=True, maximum=1e3)
    offsets = _centre_offsets(centre_offset, {d.type for d in lefts})
    source = _disparity_sources(disparity_from, {d.type for d in lefts})
    errors = disparity_errors(disparity_error, {d.type for d in lefts})
    from_outline = {t for t, v in source.items() if v == "outline"}
    rect = rig.rectify() if from_outline and rights else None
    w, h = rig.image_size
    _check_image_size("left", lefts, w, h)
    _check_image_size("right", rights, w, h)
    dropped: list[Dropped] = []

    def usable(dets: list[Detection], record: bool) -> list[int]:
        keep = []
        for i, d in enumerate(dets):
            if d.box is not None and touches_border(d.box, w, h) and not keep_cut_off:
                if record:
                    dropped.append(Dropped(i, d.type, "cut_off",
                                           f"box {d.box.tolist()} touches the border of the {w} x {h} image"))
                continue
            keep.append(i)
        return keep

    li, ri = usable(lefts, True), usable(rights, False)
    matches = match_stereo(rig, [lefts[i] for i in li], [rights[j] for j in ri], max_epipolar_px,
                           min_depth=min_depth)
    matched = {li[m.left]: ri[m.right] for m in matches}
    notes = _swapped_note(rig, [lefts[i] for i in li], [rights[j] for j in ri], len(matched),
                          max_epipolar_px, min_depth)
    for i in li:
        if i not in matched:
            dropped.append(Dropped(i, lefts[i].type, "no_stereo_match",
                                   f"no right detection of type {lefts[i].type!r} within "
                                   f"{max_epipolar_px:g} px of its epipolar line, in front of both cameras"))
    percepts: list[Percept] = []
    sources: list[int] = []
    for i in sorted(matched):
        dl, dr = lefts[i], rights[matched[i]]
        differ = extents_differ(dl, dr)
        if differ:
            dropped.append(Dropped(i, dl.type, "occluded", differ))
            continue
        uv_l, uv_r = np.asarray(dl.centroid_uv)[None, :], np.asarray(dr.centroid_uv)[None, :]
        middle = (None if rect is None or dl.type not in from_outline or dl.mask is None or dr.mask is None
                  else extent_middle(dl))
        outline = None if middle is None else outline_disparity(rig, dl, dr, rect, at=middle)
        if outline is not None and outline.disparity <= 0.0:
            outline = None  # the outlines of a mismatched or far pair: the centroids say more
        if outline is not None and middle is not None:  # the extent middle's match, less the bias
            uv_l = middle[None, :]
            err = errors[dl.type]
            uv_r = (outline.uv_right - err.bias_px * outline.duv_right)[None, :]
        try:
            X = np.asarray(rig.triangulate(uv_l, uv_r), dtype=np.float64)[0]
            J = triangulation_jacobian(rig, uv_l, uv_r)[0]  # (3, 4)
        except PerceptionError as exc:
            dropped.append(Dropped(i, dl.type, "behind_camera", str(exc)))
            continue
        common = J[:, :2] + J[:, 2:]  # the same shift in both images
        if outline is None:
            own = px * px * (J @ J.T)
        else:
            along = J[:, 2:] @ outline.duv_right  # a disparity error moves the match along its epipolar line
            own = px * px * (common @ common.T) + err.variance(outline) * np.outer(along, along)
        shape = 0.5 * (np.asarray(dl.shape_covariance) + np.asarray(dr.shape_covariance))
        cut = (dl.box is not None and touches_border(dl.box, w, h)) or (
            dr.box is not None and touches_border(dr.box, w, h))
        ray = X / np.linalg.norm(X)
        spread = common @ shape @ common.T  # the region's pixel spread, in metres at the object
        prior = offsets.get(dl.type)
        if prior is not None:
            d, d_sd = prior.depth, float(prior.depth_sd)  # type: ignore[arg-type]  # set in __post_init__
        else:
            d, d_sd = 0.0, CENTRE_DEPTH_SIGMA
        loading = np.column_stack([ray * d_sd, _lateral(ray, spread, prior, cut)])
        sigma = None if depth_factor is None else float(depth_sigma(float(X[2]), depth_factor))
        try:
            percepts.append(_percept(dl, X + d * ray, own, loading, T, sigma))
        except PerceptionError as exc:
            dropped.append(Dropped(i, dl.type, "behind_camera", f"no valid covariance: {exc}"))
            continue
        sources.append(i)
    return DetectionPercepts(tuple(percepts), tuple(sources), tuple(dropped), notes)


#: :func:`stereo_percepts` notes swapped cameras when at least this many detections would match
#: with the images swapped, and more than twice as many as match as given.
SWAPPED_MIN_MATCHES = 3


#: Where a stereo pair's disparity comes from (:func:`stereo_percepts`).
DisparitySource = Literal["centroids", "outline"]


def _disparity_sources(value: object, types: set[str]) -> dict[str, str]:
    """``disparity_from`` as the source of each of ``types`` (a mapping's missing types: the
    centroids)."""
    def one(name: str, v: object) -> str:
        if not isinstance(v, str) or v not in ("outline", "centroids"):
            raise PerceptionError(f"{name} must be 'outline' or 'centroids', got {_short(v)}")
        return v

    if isinstance(value, Mapping):
        given = {name_string("disparity_from key", k): one(f"disparity_from[{k!r}]", v)
                 for k, v in value.items()}
        return {t: given.get(t, "centroids") for t in types}
    return dict.fromkeys(types, one("disparity_from", value))


def extent_middle(det: Detection) -> NDArray[np.float64]:
    """The middle of a detection's extent in the image (its box's centre)."""
    assert det.box is not None
    return np.array([0.5 * (det.box[0] + det.box[2]), 0.5 * (det.box[1] + det.box[3])])


def _check_image_size(name: str, dets: list[Detection], w: int, h: int) -> None:
    """Masks of the rig's image size (``(height, width)`` = ``(h, w)``); a size that fits only
    transposed names the rig's ``image_size`` as the likely mistake."""
    for i, d in enumerate(dets):
        if d.mask is None or d.mask.shape == (h, w):
            continue
        if d.mask.shape == (w, h):
            raise PerceptionError(
                f"{name}[{i}].mask has shape {d.mask.shape} (height, width) but rig.image_size is "
                f"({w}, {h}): image_size is (width, height); did you give ({h}, {w})?")
        raise PerceptionError(f"{name}[{i}].mask has shape {d.mask.shape} (height, width); the rig's "
                              f"images are {w} x {h} (rig.image_size = ({w}, {h}))")


def _swapped_note(rig: Any, lefts: list[Detection], rights: list[Detection], matched: int,
                  max_epipolar_px: float, min_depth: float) -> tuple[str, ...]:
    """A note when the detections pair up far better with the cameras swapped (their disparity
    negative as given)."""
    if len(lefts) < SWAPPED_MIN_MATCHES or matched * 2 >= len(lefts):
        return ()
    # the same rig with the two images' detections exchanged
    crossed = len(match_stereo(rig, rights, lefts, max_epipolar_px, min_depth=min_depth))
    if crossed >= SWAPPED_MIN_MATCHES and crossed > 2 * matched:
        return (f"most detections match with negative disparity ({crossed} of {len(lefts)} pair up "
                f"with the cameras swapped, {matched} as given): are left and right swapped?",)
    return ()
