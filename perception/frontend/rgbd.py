"""The depth (RGB-D) front end: detections and a registered depth image to percepts
(:func:`rgbd_percepts`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._checks import boolean, integer, real_scalar
from ..errors import PerceptionError
from ..head.chain import check_transform
from ..tolerances import DEPTH_COVARIANCE_FLOOR
from .detection import Detection
from .detection_percepts import (
    CENTRE_DEPTH_SIGMA,
    DEPTH_CORRELATION_PX,
    DEPTH_NOISE,
    MASK_BLEED_PX,
    MAX_CAMERA_DEPTH,
    MAX_DEPTH,
    MAX_REGION_SAMPLES,
    MIN_CORE_PX,
    OCCLUDED_FRACTION,
    OCCLUSION_MARGIN,
    CentreOffset,
    DetectionPercepts,
    Dropped,
    _camera_matrix,
    _centre_offsets,
    _depth_image,
    _detections,
    _lateral,
    _percept,
    touches_border,
    visible_anchor,
)
from .percept import Percept

__all__ = ["rgbd_percepts"]

# ----------------------------------------------------------------------------------------------
# RGB-D
# ----------------------------------------------------------------------------------------------
def _region(det: Detection, shape: tuple[int, int], index: int) -> tuple[NDArray[np.bool_], bool]:
    """The detection's pixels in an image of ``shape`` and whether they come from a box."""
    h, w = shape
    if det.mask is not None:
        if det.mask.shape != (h, w):
            raise PerceptionError(f"detections[{index}].mask has shape {det.mask.shape}; the depth image is "
                                  f"{h} x {w} (the mask must cover the whole image the depth is "
                                  "registered to)")
        return det.mask, False
    box = det.box
    if box is None:
        raise PerceptionError(f"detections[{index}] has neither a mask nor a box: the depth front end "
                              "needs the object's pixels (a centroid alone does not say which depths are "
                              "the object's)")
    if box[2] < 0 or box[3] < 0 or box[0] > w - 1 or box[1] > h - 1:
        raise PerceptionError(f"detections[{index}].box = {box.tolist()} lies outside the {w} x {h} depth "
                              f"image")
    u0, v0 = max(0, int(np.ceil(box[0]))), max(0, int(np.ceil(box[1])))
    u1, v1 = min(w - 1, int(np.floor(box[2]))), min(h - 1, int(np.floor(box[3])))
    mask = np.zeros((h, w), dtype=bool)
    mask[v0:v1 + 1, u0:u1 + 1] = True
    return mask, True


def _depth_window(seed: NDArray[np.float64], sigma_z: float) -> tuple[float, float]:
    """The depths that belong to the object, ``(nearest, farthest)``: a robust window about the
    seed pixels' median (3 scaled MADs, at least 3 sigma_z and 1 cm)."""
    med = float(np.median(seed))
    mad = 1.4826 * float(np.median(np.abs(seed - med)))
    half = max(3.0 * mad, 3.0 * sigma_z, 0.01)
    return med - half, med + half


def _mask_window(mask: NDArray[np.bool_], box: NDArray[np.float64], depth: NDArray[np.float64], c: float
                 ) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """The depths of a mask's object, two ``(nearest, farthest)`` windows: ``own``, the range of
    its core's readings (the mask eroded by :data:`MASK_BLEED_PX`, which a detector's bleeding
    edge does not reach) widened by 3 sigma_z and 1 cm, the readings the occlusion test takes
    for the object's own; and ``surface``, ``own`` widened further by the depth the core's
    surface gains over the eroded edge (a slanted face's far edge), the object's points.  Unlike
    a window about the median, they keep the whole of a slanted door and a handle before its
    leaf.  None when the core holds fewer than :data:`MIN_CORE_PX` readings (a small or thin
    mask)."""
    import cv2

    v0, v1 = max(0, int(box[1])), min(mask.shape[0], int(box[3]) + 1)
    u0, u1 = max(0, int(box[0])), min(mask.shape[1], int(box[2]) + 1)
    side = 2 * MASK_BLEED_PX + 1
    core = cv2.erode(mask[v0:v1, u0:u1].astype(np.uint8), np.ones((side, side), np.uint8),
                     borderValue=0).astype(bool)
    crop = np.where(core, depth[v0:v1, u0:u1], np.nan)
    z = crop[np.isfinite(crop)]
    if z.size < MIN_CORE_PX:
        return None
    # the edge the erosion took off continues the core's surface: as far in depth as the core's
    # steepest steps (95th percentile, per pixel across and down) times the pixels taken off
    steps = np.concatenate([np.abs(np.diff(crop, axis=1)).ravel(), np.abs(np.diff(crop, axis=0)).ravel()])
    steps = steps[np.isfinite(steps)]
    slope = float(np.percentile(steps, 95)) if steps.size else 0.0
    lo, hi = float(z.min()), float(z.max())
    margin = 3.0 * c * hi * hi + 0.01
    edge = (MASK_BLEED_PX + 1) * slope
    return (lo - margin, hi + margin), (lo - margin - edge, hi + margin + edge)


def depth_windows(mask: NDArray[np.bool_] | None, box: NDArray[np.float64], depth: NDArray[np.float64],
                   c: float, seed: NDArray[np.float64]) -> tuple[tuple[float, float], tuple[float, float]]:
    """The object's depths as ``(own, surface)`` windows: a mask's (``_mask_window``), else,
    for a box (``mask`` None) or a mask whose core is too small, the window about the median of
    the ``seed`` readings (``_depth_window``) for both."""
    windows = None if mask is None else _mask_window(mask, box, depth, c)
    if windows is None:
        window = _depth_window(seed, c * float(np.median(seed)) ** 2)
        windows = (window, window)
    return windows


def _box_seed(u: NDArray[np.intp], v: NDArray[np.intp], z: NDArray[np.float64], box: NDArray[np.float64],
              c: float, focal: float) -> NDArray[np.float64]:
    """The depths of a box's pixels that seed the object's depth window.  The object is nearer
    than the background around it and fills the box's centre: the seed is the central half's
    depths within half the box's metric width of their 25th percentile (an object extends in
    depth no more than across)."""
    cu, cv = 0.5 * (box[0] + box[2]), 0.5 * (box[1] + box[3])
    central = ((np.abs(u - cu) <= 0.25 * (box[2] - box[0] + 1))
               & (np.abs(v - cv) <= 0.25 * (box[3] - box[1] + 1)))
    zc = z[central] if central.sum() >= 3 else z
    near = float(np.percentile(zc, 25))
    width = (min(box[2] - box[0], box[3] - box[1]) + 1.0) * near / focal
    half = max(3.0 * c * near * near, 0.01, 0.5 * width)
    return zc[np.abs(zc - near) <= half]


def _occluded_fraction(mask: NDArray[np.bool_], box: NDArray[np.float64], depth: NDArray[np.float64],
                       window: tuple[float, float], from_box: bool, margin: float) -> float:
    """Fraction of the valid readings in a 3-pixel ring outside the region's outer outline that
    lie nearer than the object's own nearest reading within 3 pixels of them, by more than
    ``margin``: a nearer surface hides part of the object there (a slanted object's edge
    continues its own surface and does not count).  The object's own readings are the region's
    within its depth ``window`` (a mask that bleeds onto the occluder does not make the
    occluder the object's own); the outline is a mask's own, or a box's object pixels'."""
    import cv2

    v0, v1 = max(0, int(box[1]) - 4), min(mask.shape[0], int(box[3]) + 5)
    u0, u1 = max(0, int(box[0]) - 4), min(mask.shape[1], int(box[2]) + 5)
    mask, depth = mask[v0:v1, u0:u1], depth[v0:v1, u0:u1]  # the outline's neighbourhood only
    with np.errstate(invalid="ignore"):
        object_px = mask & (depth >= window[0]) & (depth <= window[1])
    if from_box:
        mask = object_px
    m8 = mask.astype(np.uint8)
    contours, _ = cv2.findContours(m8, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    filled = np.zeros_like(m8)
    cv2.drawContours(filled, contours, -1, 1, thickness=cv2.FILLED)
    kernel = np.ones((7, 7), np.uint8)
    ring = cv2.dilate(filled, kernel).astype(bool) & ~filled.astype(bool)
    none = np.float32(1e30)  # no reading of the object's (cv2 turns inf into the float32 maximum)
    own = np.where(object_px, depth, none).astype(np.float32)
    nearest_own = cv2.erode(own, kernel)  # the object's nearest reading within 3 pixels
    zr, zo = depth[ring], nearest_own[ring]
    keep = np.isfinite(zr) & (zo < none)
    if not keep.any():
        return 0.0
    return float(np.mean(zr[keep] < zo[keep] - margin))


def rgbd_percepts(
    detections: Sequence[Detection],
    depth: ArrayLike,
    K: ArrayLike,
    ego_from_camera: ArrayLike,
    *,
    depth_noise: float = DEPTH_NOISE,
    depth_correlation_px: float = DEPTH_CORRELATION_PX,
    centre_offset: float | CentreOffset | Mapping[str, float | CentreOffset] | None = None,
    min_pixels: int = 20,
    keep_cut_off: bool = False,
    max_depth: float = MAX_CAMERA_DEPTH,
) -> DetectionPercepts:
    """Percepts from detections and a registered depth image (an RGB-D camera).

    For each detection: its pixels (the mask, else the box), their valid depth readings, the
    object's among them (the depth range of the mask's core, eroded by :data:`MASK_BLEED_PX`; a
    robust depth window about the median of a small mask or of a box's central half; so
    background inside a box or at a mask's bleeding edge drops out), back-projected through ``K``
    into camera points; the percept is their anchor (the centroid along the offset direction,
    the middle of their extent across it, on axes of the ego frame's up) moved to the object's
    centre (module docstring), mapped by ``ego_from_camera``.  Its covariance sums

    - the depth noise ``sigma_z = depth_noise * z^2`` along the centroid's ray, averaged over
      ``max(1, N / depth_correlation_px**2)`` independent patches of the ``N`` pixels;
    - the centre offset (shared by the object's views, id :data:`~perception.OBJECT_VIEW`): the
      centre depth's uncertainty along the offset direction and
      :data:`CENTRE_OFFSET_SCALE` times the visible part's spread across it.

    Parameters
    ----------
    detections : sequence of Detection
        With a ``mask`` of the depth image's size, or a ``box``.
    depth : (height, width) float
        Depth along the optical axis (the camera-frame z, as OpenCV and ROS depth images), metres,
        registered to the detections' image; 0, NaN or inf where the sensor has no reading.
    K : (3, 3) float
        Camera matrix of the depth image (pixels; undistorted image).
    ego_from_camera : (4, 4) float
        Rigid transform from the camera frame (OpenCV: x right, y down, z ahead) to the ego
        frame (x forward, y left, z up), e.g. :meth:`perception.KinematicChain.ego_from_camera`;
        ``numpy.eye(4)`` gives camera-frame percepts, which ``localize`` cannot use as they are.
    depth_noise : float
        ``c`` of ``sigma_z = c z^2``, 1/m; default :data:`DEPTH_NOISE`.
    depth_correlation_px : float
        Default :data:`DEPTH_CORRELATION_PX`.
    centre_offset : CentreOffset, float, or mapping of str to CentreOffset or float, optional
        Per type, where the object's centre lies from its visible part's centroid (module
        docstring); a float is the depth of a :class:`CentreOffset` with default uncertainties;
        one value (not a mapping) applies to every type.  Types without one use the visible
        surface's own relief.
    min_pixels : int
        Fewest valid object pixels for a percept.
    keep_cut_off : bool
        Keep regions that touch the image border, with the centre's position across the view
        as uncertain as the visible part is wide.
    max_depth : float
        The camera's range (m, default :data:`MAX_CAMERA_DEPTH`): a depth image whose median
        reading lies beyond it is refused as not in metres.

    Returns
    -------
    DetectionPercepts

    Raises
    ------
    PerceptionError
        A depth image that is not 2D float metres (integer depth is named as millimetres, and a
        median reading beyond ``max_depth`` as not metres, with what it would be in centimetres
        and millimetres), negative depth, a mask of another
        size than the depth image, a box outside it, a bad ``K`` or transform.
    """
    dets = _detections("detections", detections)
    Z = _depth_image(depth, real_scalar("max_depth", max_depth, positive=True, maximum=MAX_DEPTH))
    Kc = _camera_matrix(K)
    T = check_transform("ego_from_camera", ego_from_camera)
    c = real_scalar("depth_noise", depth_noise, positive=True, maximum=1.0)
    corr = real_scalar("depth_correlation_px", depth_correlation_px, minimum=1.0, maximum=1e4)
    min_pixels = integer("min_pixels", min_pixels, minimum=1)
    keep_cut_off = boolean("keep_cut_off", keep_cut_off)
    offsets = _centre_offsets(centre_offset, {d.type for d in dets})
    h, w = Z.shape
    Kinv = np.linalg.inv(Kc)
    up = T[:3, :3].T @ np.array([0.0, 0.0, 1.0])  # the ego frame's up, in the camera frame
    percepts: list[Percept] = []
    sources: list[int] = []
    dropped: list[Dropped] = []
    for i, det in enumerate(dets):
        mask, from_box = _region(det, (h, w), i)
        b = det.box if det.box is not None else np.array([0, 0, w - 1, h - 1], dtype=np.float64)
        u0, v0 = max(0, int(b[0])), max(0, int(b[1]))
        v, u = np.nonzero(mask[v0:min(h, int(b[3]) + 1), u0:min(w, int(b[2]) + 1)])
        v, u = v + v0, u + u0
        if u.size < min_pixels:
            dropped.append(Dropped(i, det.type, "too_few_pixels",
                                   f"{u.size} pixels < min_pixels {min_pixels}"))
            continue
        box = np.array([u.min(), v.min(), u.max(), v.max()], dtype=np.float64)
        cut = touches_border(box, w, h)
        if cut and not keep_cut_off:
            dropped.append(Dropped(i, det.type, "cut_off", f"box {box.tolist()} touches the border of the "
                                   f"{w} x {h} image"))
            continue
        z = Z[v, u]
        ok = np.isfinite(z)
        n_valid = int(ok.sum())
        if n_valid < min_pixels:
            dropped.append(Dropped(i, det.type, "no_depth", f"{n_valid} of {u.size} pixels have a depth "
                                   f"reading (< min_pixels {min_pixels})"))
            continue
        u, v, z = u[ok], v[ok], z[ok]
        stride = -(-u.size // MAX_REGION_SAMPLES)  # statistics of a large region on a regular subsample
        if stride > 1:
            u, v, z = u[::stride], v[::stride], z[::stride]
        # a box's central half, or a small mask (mostly the object) seeds a window about the median
        seed = _box_seed(u, v, z, box, c, float(Kc[0, 0])) if from_box else z
        own_depths, surface = depth_windows(None if from_box else mask, box, Z, c, seed)
        fg = (z >= surface[0]) & (z <= surface[1])
        n_fg = int(fg.sum()) * stride
        if n_fg < min_pixels:
            dropped.append(Dropped(i, det.type, "no_depth", f"{n_fg} pixels at the object's depth "
                                   f"(< min_pixels {min_pixels})"))
            continue
        u, v, z = u[fg], v[fg], z[fg]
        pts = (np.column_stack([u, v, np.ones(u.size)]) @ Kinv.T) * z[:, None]
        anchor, direction, spread = visible_anchor(pts, up)
        zc = float(anchor[2])
        sigma_z = c * zc * zc
        occ = _occluded_fraction(mask, box, Z, own_depths, from_box, OCCLUSION_MARGIN + 3.0 * sigma_z)
        if occ > OCCLUDED_FRACTION:
            dropped.append(Dropped(i, det.type, "occluded", f"{100 * occ:.0f} % of the readings around its "
                                   f"outline are nearer (> {100 * OCCLUDED_FRACTION:.0f} %)"))
            continue
        prior = offsets.get(det.type)
        if prior is not None:
            d, d_sd = prior.depth, float(prior.depth_sd)  # type: ignore[arg-type]  # set in __post_init__
        else:  # the relief of the visible surface: its far edge (the silhouette) minus its centroid
            along = (pts - anchor) @ direction
            d = max(0.0, float(np.percentile(along, 95)))
            d_sd = float(np.hypot(CENTRE_DEPTH_SIGMA, 0.5 * d))
        centre = anchor + d * direction
        loading = np.column_stack([direction * d_sd, _lateral(direction, spread, prior, cut)])
        n_eff = max(1.0, n_fg / (corr * corr))
        ray_z = anchor / zc  # a depth error dz moves the anchor by about dz * ray_z
        own = np.outer(ray_z, ray_z) * (sigma_z * sigma_z / n_eff)
        own += np.eye(3) * (DEPTH_COVARIANCE_FLOOR * sigma_z) ** 2  # keeps it positive definite
        try:
            percepts.append(_percept(det, centre, own, loading, T, None))
        except PerceptionError as exc:  # a degenerate covariance: report, never guess
            dropped.append(Dropped(i, det.type, "no_depth", f"no valid covariance: {exc}"))
            continue
        sources.append(i)
    return DetectionPercepts(tuple(percepts), tuple(sources), tuple(dropped))


