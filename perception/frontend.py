"""From a detector's output to percepts: the depth (RGB-D) and the stereo front ends.

A detector (any: a segmentation network, a box detector, :func:`perception.detect`) gives
:class:`~perception.Detection` objects per image.  Two front ends turn them into
:class:`~perception.Percept` objects in the ego frame, each with a full 3x3 covariance:

- :func:`rgbd_percepts`: detections plus a depth image registered to them (metres), the
  camera matrix and ``ego_from_camera``;
- :func:`stereo_percepts`: detections in the left and the right image of a
  :class:`~perception.StereoRig`, matched by type and the epipolar constraint and triangulated.

**What a percept's position means.** A world model places an object at the centre of its
visual geometry (:meth:`worldgraph.WorldModel.from_file`), but a camera sees its front surface:
a door's front lies half its thickness before that centre, a cylindrical handle's visible
half about two thirds of its radius.  Measured on rendered kitchens, 15 mm (door and drawer
fronts) to 30 mm (handles): enough, uncorrected, to break the association.  Both front ends
therefore refer each percept to the object's centre, ``centre = anchor + d n``, with the anchor
the visible part's centroid along ``n`` and the middle of its extent across ``n`` (RGB-D: on
gravity-aligned axes, as a box around the visible part is centred; stereo: the centroid), ``n``
the direction away from the camera (the visible surface's normal when it is flat, else the
viewing ray) and ``d`` the *centre offset* of the object's type, a prior with its uncertainty
(:class:`CentreOffset`; ``centre_offset={type: CentreOffset(...)}`` or ``{type: d}``): from the
map (:meth:`worldgraph.WorldModel.centre_depths`, half the thinnest extent), measured for your
detector's classes, or measured on renders (:meth:`perception.mujoco.MujocoScene.centre_offsets`).
Measured on the Franka kitchen, doors with their protruding handles have their centre 1.7 cm
*in front* of the visible leaf, knobs 0.8 cm and switches 2.4 cm behind what is seen.  Types
without a prior use the visible surface's own depth relief (exact for rounded objects, zero for
a flat front) with :data:`CENTRE_DEPTH_SIGMA` of uncertainty.

**Errors an object's views share.** What we do not know about ``d`` and the offset of the
visible part's centroid from the centre's image (perspective, a mask's bleeding edge) is the
same each time the object is seen: it is carried as a shared loading with the reserved id
:data:`~perception.OBJECT_VIEW` (:class:`~perception.Percept`'s ``shared``), which
:func:`perception.fuse_percepts` adds coherently over an object's views instead of averaging
it away.  The covariance of each percept includes it.

**Dropped detections** are reported with their reason (:class:`Dropped`): ``"cut_off"`` (the
region touches the image border, so its centroid is biased; ``keep_cut_off=True`` keeps it
with a covariance that covers where the centre may be), ``"occluded"`` (a nearer surface hides
part of it), ``"too_few_pixels"``, ``"no_depth"`` (too few valid depth readings in it),
``"no_stereo_match"``, ``"behind_camera"``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._checks import _short, boolean, integer, name_string, real_array, real_scalar, sequence
from .chain import check_transform
from .detection import Detection
from .errors import PerceptionError
from .outline import DisparityError, disparity_errors, outline_disparity
from .percept import OBJECT_VIEW, Percept
from .tolerances import DEPTH_COVARIANCE_FLOOR

__all__ = [
    "CENTRE_DEPTH_SIGMA",
    "CENTRE_OFFSET_SCALE",
    "CentreOffset",
    "DEPTH_CORRELATION_PX",
    "DEPTH_NOISE",
    "DetectionPercepts",
    "DropReason",
    "Dropped",
    "rgbd_percepts",
    "stereo_percepts",
]

#: Default coefficient ``c`` of the depth camera's noise model ``sigma_z = c z^2`` (z the depth
#: in metres, ``c`` in 1/m): 1.5e-3, about what Khoshelham and Elberink (2012, "Accuracy and
#: resolution of Kinect depth data") report for a structured-light sensor (1.5 mm at 1 m, 4 cm
#: at 5 m).  Pass your sensor's own with ``depth_noise=``.
DEPTH_NOISE = 1.5e-3
#: Default correlation length of depth errors, pixels: errors of pixels closer than this are
#: taken as one (a depth camera's disparity is matched over patches), so a region of ``N``
#: pixels averages ``max(1, N / DEPTH_CORRELATION_PX**2)`` independent depth errors.
DEPTH_CORRELATION_PX = 8.0
#: Standard deviation of the offset between the centroid of an object's visible part and the
#: object's centre, across the viewing direction, as a fraction of the visible part's own
#: extent (standard deviation of its points per axis): perspective, mask edges, self-occlusion.
CENTRE_OFFSET_SCALE = 0.1
#: Standard deviation (m) of the centre depth ``d`` when it is estimated from the visible
#: surface (no ``centre_offset`` for the type): covers the half thickness of a flat front
#: (doors, drawers, 1-3 cm), which a depth image cannot see.
CENTRE_DEPTH_SIGMA = 0.02
#: Default relative standard deviation of a :class:`CentreOffset` depth (plus
#: :data:`CENTRE_DEPTH_FLOOR`).
CENTRE_DEPTH_RTOL = 0.5
#: Absolute floor (m) of the default standard deviation of a :class:`CentreOffset` depth.
CENTRE_DEPTH_FLOOR = 0.005
#: Largest centre offset (``|depth|``, its standard deviations) accepted, metres.
MAX_CENTRE_DEPTH = 10.0
#: Range of a camera matrix's focal lengths accepted (pixels).
MIN_FOCAL_PX, MAX_FOCAL_PX = 1.0, 1e7
#: Smallest and largest depth reading accepted (m); 0, NaN and inf are "no reading".
MIN_DEPTH, MAX_DEPTH = 0.001, 1e4
#: The farthest a depth camera reads (m), by default: :func:`rgbd_percepts` takes a depth image
#: whose median valid reading lies beyond its ``max_depth`` for another unit than metres.
MAX_CAMERA_DEPTH = 20.0
#: A region is occluded when more than this fraction of the valid depth readings just outside
#: its outline lie nearer than its own nearby readings (by :data:`OCCLUSION_MARGIN`).
OCCLUDED_FRACTION = 0.2
#: How much nearer (m, plus 3 sigma_z) a reading just outside the outline must be to occlude.
OCCLUSION_MARGIN = 0.03
#: Largest number of a region's pixels its statistics are computed from (a regular subsample
#: of larger regions; the pixel count still sets how much the depth noise averages out).
MAX_REGION_SAMPLES = 2048
#: Pixels a detector's mask may bleed onto its neighbours: the mask's core, eroded by this,
#: sets which depths are the object's (:func:`rgbd_percepts`).
MASK_BLEED_PX = 2
#: Fewest readings in a mask's core for its depth range to stand for the object's.
MIN_CORE_PX = 20
#: Percentile of a visible part's points that bounds its extent (and its upper counterpart):
#: the middle of the extent places an object across the view (:func:`rgbd_percepts`).
EXTENT_PERCENTILE = 1.0
#: Smallest cosine between a flat front's normal and a viewing ray taken for a pixel's surface
#: (a face seen edge-on would otherwise give its last pixels unbounded weight).
MIN_FACING = 0.05
#: A visible surface is flat when its smallest spread is below this fraction of the middle one
#: (its normal then orients the centre offset).
FLAT_RATIO = 0.1

DropReason = Literal["cut_off", "occluded", "too_few_pixels", "no_depth", "no_stereo_match", "behind_camera"]


@dataclass(frozen=True)
class Dropped:
    """A detection a front end turned into no percept, and why.

    Attributes
    ----------
    index : int
        Index of the detection (for :func:`stereo_percepts`, in the left list).
    type : str
        Its type.
    reason : DropReason
        ``"cut_off"``, ``"occluded"``, ``"too_few_pixels"``, ``"no_depth"``,
        ``"no_stereo_match"`` or ``"behind_camera"``.
    detail : str
        The numbers behind the reason.
    """

    index: int
    type: str
    reason: DropReason
    detail: str


@dataclass(frozen=True)
class DetectionPercepts:
    """What a front end made of one image's (or stereo pair's) detections.

    Attributes
    ----------
    percepts : tuple of Percept
        In the ego frame (the frame ``ego_from_camera`` maps to).
    sources : tuple of int
        For each percept, the index of its detection (left list for stereo).
    dropped : tuple of Dropped
        Every detection that gave no percept, with its reason.
    notes : tuple of str
        What the front end noticed about the input as a whole and the caller should hear (for
        stereo: most detections match with negative disparity, so left and right look swapped).
    """

    percepts: tuple[Percept, ...]
    sources: tuple[int, ...]
    dropped: tuple[Dropped, ...]
    notes: tuple[str, ...] = ()


# ----------------------------------------------------------------------------------------------
# argument checks
# ----------------------------------------------------------------------------------------------
def _camera_matrix(value: ArrayLike) -> NDArray[np.float64]:
    K = real_array("K", value, (3, 3))
    if not (K[0, 0] > 0 and K[1, 1] > 0) or not np.allclose(K[2], [0.0, 0.0, 1.0]) or K[1, 0] != 0:
        raise PerceptionError(f"K must be a camera matrix [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with fx, "
                              f"fy > 0, "
                         f"got {K.tolist()}")
    if not (MIN_FOCAL_PX <= K[0, 0] <= MAX_FOCAL_PX and MIN_FOCAL_PX <= K[1, 1] <= MAX_FOCAL_PX) or \
            np.any(np.abs(K[:2, 1:]) > MAX_FOCAL_PX):
        raise PerceptionError(f"K: focal lengths must lie in [{MIN_FOCAL_PX:g}, {MAX_FOCAL_PX:g}] px and "
                              f"the skew "
                         f"and principal point within {MAX_FOCAL_PX:g} px, got {K.tolist()}")
    return K


def _depth_image(value: ArrayLike, max_depth: float = MAX_CAMERA_DEPTH) -> NDArray[np.float64]:
    """A (h, w) depth image in metres: NaN, inf and 0 are holes; negative readings are refused, and
    so is an image whose median reading lies beyond the camera's range ``max_depth`` (m), naming
    what the readings would be in centimetres and in millimetres."""
    raw = np.asarray(value) if not isinstance(value, (str, bytes)) else None
    if raw is None or raw.ndim != 2 or raw.shape[0] < 1 or raw.shape[1] < 1:
        shape = None if raw is None else raw.shape
        raise PerceptionError(f"depth must be a 2D (height, width) image in metres, got shape {shape}")
    if raw.dtype.kind in "iu":
        raise PerceptionError(
            f"depth has integer dtype {raw.dtype}: depth cameras store millimetres in uint16; pass "
            "depth.astype(float) / 1000.0 (metres, with 0 for no reading)")
    if raw.dtype.kind != "f":
        raise PerceptionError(f"depth must be a float image in metres, got dtype {raw.dtype}")
    depth = raw.astype(np.float64)
    neg = np.argwhere(depth < 0)
    if len(neg):
        r, c = neg[0]
        raise PerceptionError(f"depth[{r}, {c}] = {float(depth[r, c])!r} is negative; a depth image holds "
                              "distances along the optical axis (0 or NaN for no reading)")
    valid = np.isfinite(depth) & (depth > 0)
    odd = np.argwhere(valid & ((depth < MIN_DEPTH) | (depth > MAX_DEPTH)))
    if len(odd):
        r, c = odd[0]
        raise PerceptionError(f"depth[{r}, {c}] = {float(depth[r, c])!r} m lies outside [{MIN_DEPTH:g}, "
                              f"{MAX_DEPTH:g}] m, the readings a depth camera gives "
                              "(0 or NaN for no reading)")
    sample = depth[::4, ::4][valid[::4, ::4]]
    if sample.size:
        med = float(np.median(sample))
        if med > max_depth:
            fits = [f"as {unit} {med / scale:.3g} m (pass depth / {scale:g})"
                    for unit, scale in (("centimetres", 100.0), ("millimetres", 1000.0))
                    if MIN_DEPTH <= med / scale <= max_depth]
            hint = "; ".join(fits) if fits else "no common unit brings them within it"
            raise PerceptionError(
                f"depth readings have median {med:.4g}, beyond the camera's range max_depth = "
                f"{max_depth:g} m, so they are not metres: {hint}; or pass max_depth= if the camera "
                "reaches farther")
    return np.where(valid, depth, np.nan)


@dataclass(frozen=True)
class CentreOffset:
    """Where an object's centre lies from the centroid of its visible part: a per-type prior.

    Parameters
    ----------
    depth : float
        Mean distance (m) from the visible part's centroid to the centre along the direction
        away from the camera (the visible surface's normal when flat, else the viewing ray);
        negative when the centre lies in front of it (a door whose handle protrudes).
    depth_sd : float, optional
        Its standard deviation (m); default ``CENTRE_DEPTH_RTOL |depth| + CENTRE_DEPTH_FLOOR``.
    lateral_sd : float, optional
        Standard deviation (m, per axis) of the centre's offset across the view; default
        :data:`CENTRE_OFFSET_SCALE` times the visible part's spread (per axis).

    Measure them for your detector's classes (a :class:`perception.mujoco.MujocoScene` measures
    them on renders: :meth:`~perception.mujoco.MujocoScene.centre_offsets`), or take the depth
    from the map (:meth:`worldgraph.WorldModel.centre_depths`).
    """

    depth: float
    depth_sd: float | None = None
    lateral_sd: float | None = None

    def __post_init__(self) -> None:
        d = real_scalar("depth", self.depth, minimum=-MAX_CENTRE_DEPTH, maximum=MAX_CENTRE_DEPTH)
        sd = (CENTRE_DEPTH_RTOL * abs(d) + CENTRE_DEPTH_FLOOR if self.depth_sd is None
              else real_scalar("depth_sd", self.depth_sd, positive=True, maximum=MAX_CENTRE_DEPTH))
        lat = None if self.lateral_sd is None else real_scalar("lateral_sd", self.lateral_sd, positive=True,
                                                                 maximum=MAX_CENTRE_DEPTH)
        object.__setattr__(self, "depth", d)
        object.__setattr__(self, "depth_sd", sd)
        object.__setattr__(self, "lateral_sd", lat)


def _offset_of(name: str, value: object) -> CentreOffset:
    if isinstance(value, CentreOffset):
        return value
    try:
        return CentreOffset(real_scalar(name, value, minimum=-MAX_CENTRE_DEPTH, maximum=MAX_CENTRE_DEPTH))
    except PerceptionError as exc:
        raise type(exc)(f"{name} must be a CentreOffset or a depth in metres: {exc}") from exc


def _centre_offsets(value: object, types: set[str]) -> dict[str, CentreOffset]:
    """Per type the prior of ``centre_offset`` (a mapping, one value for every type, or None)."""
    if value is None:
        return {}
    if isinstance(value, Mapping):
        return {str(t): _offset_of(f"centre_offset[{t!r}]", d) for t, d in value.items()}
    one = _offset_of("centre_offset", value)
    return dict.fromkeys(types, one)


def _lateral(direction: NDArray[np.float64], spread: NDArray[np.float64], prior: CentreOffset | None,
             cut: bool) -> NDArray[np.float64]:
    """(3, 2) loading of the centre's offset across ``direction``: the prior's ``lateral_sd``
    (isotropic) or :data:`CENTRE_OFFSET_SCALE` times the visible part's spread ``spread`` (3x3
    covariance); a cut-off region's centre may lie anywhere within its own extent."""
    P = np.eye(3) - np.outer(direction, direction)
    w, V = np.linalg.eigh(P @ (0.5 * (spread + spread.T)) @ P)
    axes, ext = V[:, 1:], np.sqrt(np.clip(w[1:], 0.0, None))  # the two directions across ``direction``
    if prior is not None and prior.lateral_sd is not None:
        sd = np.full(2, prior.lateral_sd)
    else:
        sd = CENTRE_OFFSET_SCALE * ext
    if cut:
        sd = np.maximum(sd, ext)
    return axes * sd


def _detections(name: str, value: object) -> list[Detection]:
    return sequence(name, value, Detection)


def _touches_border(box: NDArray[np.float64], width: int, height: int) -> bool:
    return bool(box[0] <= 0 or box[1] <= 0 or box[2] >= width - 1 or box[3] >= height - 1)


# ----------------------------------------------------------------------------------------------
# geometry shared by both front ends
# ----------------------------------------------------------------------------------------------
def _offset_direction(pts: NDArray[np.float64], centroid: NDArray[np.float64]
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64], bool]:
    """The direction (unit, camera frame) in which an object's centre lies behind the centroid of
    its visible points ``pts``: the normal of a flat front (smallest spread below
    :data:`FLAT_RATIO` times the middle one) pointing away from the camera, else the viewing ray;
    the points' spread (3x3 covariance); and whether the front is flat."""
    spread = np.cov(pts.T, bias=True) if len(pts) > 1 else np.zeros((3, 3))
    ray = centroid / np.linalg.norm(centroid)
    wv, V = np.linalg.eigh(spread)
    if wv[0] < FLAT_RATIO * wv[1]:  # a flat front: its normal, away from the camera
        return (V[:, 0] if V[:, 0] @ ray > 0 else -V[:, 0]), spread, True
    return ray, spread, False


def _weighted_percentiles(x: NDArray[np.float64], w: NDArray[np.float64], q: float) -> NDArray[np.float64]:
    """The ``q``-th percentile of each column of ``x`` (n, m) under weights ``w`` (n,): the first
    value, in sorted order, whose cumulative weight reaches ``q`` % of the total."""
    order = np.argsort(x, axis=0)
    cum = np.cumsum(w[order], axis=0)
    at = np.argmax(cum >= (q / 100.0) * cum[-1], axis=0)
    return x[order[at, np.arange(x.shape[1])], np.arange(x.shape[1])]


def _visible_anchor(pts: NDArray[np.float64], up: NDArray[np.float64]
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Where an object's visible points ``pts`` (camera frame) put it before the centre offset:
    ``(anchor, direction, spread)``.  Along ``direction`` (``_offset_direction``) the anchor
    is the points' centroid; across it, the middle of their extent (1st to 99th percentile) on
    the axes ``up`` (the ego frame's z in the camera frame) and the points' main horizontal
    directions.  The middle of the extent is where the centre of a box around the visible part
    lies, whatever the perspective: the centroid of pixels leans towards the nearer side of a
    slanted face and towards the bulk of an uneven shape (a kettle's body, not its spout)."""
    centroid = pts.mean(axis=0)
    direction, spread, flat_front = _offset_direction(pts, centroid)
    up = up / np.linalg.norm(up)
    rel = pts - centroid
    level = rel - np.outer(rel @ up, up)  # the points' spread with the vertical taken out
    _, V = np.linalg.eigh(level.T @ level)
    axes = np.stack([up, V[:, 2], np.cross(up, V[:, 2])])
    # each pixel stands for the surface it images: z^3 / (f^2 |n . p|) on a flat front of normal
    # n (z^3 / (f^2 |p|) facing the camera), so the extent's percentiles are the surface's, not
    # the pixels' (which crowd at the near end of a slanted face)
    dist = np.linalg.norm(pts, axis=1)
    facing = np.abs(pts @ direction) if flat_front else dist
    weight = pts[:, 2] ** 3 / np.maximum(facing, MIN_FACING * dist)
    coords = pts @ axes.T
    lo = _weighted_percentiles(coords, weight, EXTENT_PERCENTILE)
    hi = _weighted_percentiles(coords, weight, 100.0 - EXTENT_PERCENTILE)
    middle = axes.T @ (0.5 * (lo + hi))
    across = middle - centroid
    return centroid + across - (across @ direction) * direction, direction, spread


def _percept(det: Detection, centre: NDArray[np.float64], own: NDArray[np.float64],
             loading: NDArray[np.float64], transform: NDArray[np.float64], sigma: float | None) -> Percept:
    """The ego-frame percept of a camera-frame centre with its own covariance and shared loading."""
    R = transform[:3, :3]
    p = R @ centre + transform[:3, 3]
    # the symmetric square root of the offset's covariance in the ego frame: every view of the
    # object then loads the same error vector (the object's offset, fixed in the ego frame while
    # the head scans) on the same axes, so fusion adds the views' loadings coherently
    w, V = np.linalg.eigh(R @ loading @ loading.T @ R.T)
    S = (V * np.sqrt(np.clip(w, 0.0, None))) @ V.T
    C = R @ own @ R.T + S @ S.T
    C = 0.5 * (C + C.T)
    shared = ((OBJECT_VIEW, S),)
    if sigma is None:  # Percept derives the range's standard deviation from C
        return Percept(det.type, p, covariance=C, shared=shared)
    return Percept(det.type, p, sigma, covariance=C, shared=shared)


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
                              f"needs the "
                         "object's pixels (a centroid alone does not say which depths are the object's)")
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


def _depth_windows(mask: NDArray[np.bool_] | None, box: NDArray[np.float64], depth: NDArray[np.float64],
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
        cut = _touches_border(box, w, h)
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
        own_depths, surface = _depth_windows(None if from_box else mask, box, Z, c, seed)
        fg = (z >= surface[0]) & (z <= surface[1])
        n_fg = int(fg.sum()) * stride
        if n_fg < min_pixels:
            dropped.append(Dropped(i, det.type, "no_depth", f"{n_fg} pixels at the object's depth "
                                   f"(< min_pixels {min_pixels})"))
            continue
        u, v, z = u[fg], v[fg], z[fg]
        pts = (np.column_stack([u, v, np.ones(u.size)]) @ Kinv.T) * z[:, None]
        anchor, direction, spread = _visible_anchor(pts, up)
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


# ----------------------------------------------------------------------------------------------
# stereo
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


def _extents_differ(a: Detection, b: Detection) -> str:
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
        :data:`perception.outline.MIN_OUTLINE_ROWS` rows or with a disparity that is not
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
    from .recognition import DISPARITY_STD_PX, match_stereo
    from .stereo import StereoRig
    from .uncertainty import depth_sigma, triangulation_jacobian

    if not isinstance(rig, StereoRig):
        raise PerceptionError(f"rig must be a perception.StereoRig, got {type(rig).__name__}")
    lefts = _detections("left", left)
    rights = _detections("right", right)
    T = check_transform("ego_from_camera", ego_from_camera)
    keep_cut_off = boolean("keep_cut_off", keep_cut_off)
    max_epipolar_px = real_scalar("max_epipolar_px", max_epipolar_px, positive=True, maximum=1e6)
    min_depth = real_scalar("min_depth", min_depth, nonnegative=True, maximum=1e6)
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
            if d.box is not None and _touches_border(d.box, w, h) and not keep_cut_off:
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
        differ = _extents_differ(dl, dr)
        if differ:
            dropped.append(Dropped(i, dl.type, "occluded", differ))
            continue
        uv_l, uv_r = np.asarray(dl.centroid_uv)[None, :], np.asarray(dr.centroid_uv)[None, :]
        middle = (None if rect is None or dl.type not in from_outline or dl.mask is None or dr.mask is None
                  else _extent_middle(dl))
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
        cut = (dl.box is not None and _touches_border(dl.box, w, h)) or (
            dr.box is not None and _touches_border(dr.box, w, h))
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


def _extent_middle(det: Detection) -> NDArray[np.float64]:
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
    from .recognition import match_stereo

    if len(lefts) < SWAPPED_MIN_MATCHES or matched * 2 >= len(lefts):
        return ()
    # the same rig with the two images' detections exchanged
    crossed = len(match_stereo(rig, rights, lefts, max_epipolar_px, min_depth=min_depth))
    if crossed >= SWAPPED_MIN_MATCHES and crossed > 2 * matched:
        return (f"most detections match with negative disparity ({crossed} of {len(lefts)} pair up "
                f"with the cameras swapped, {matched} as given): are left and right swapped?",)
    return ()
