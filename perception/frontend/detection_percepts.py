"""What the two front ends from detections share: the result types (:class:`DetectionPercepts`,
:class:`Dropped`), the centre-offset prior (:class:`CentreOffset`) and where a percept's centre
lies from the visible part of its object."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._checks import real_array, real_scalar, sequence
from ..errors import PerceptionError
from .detection import Detection
from .percept import OBJECT_VIEW, Percept

__all__ = [
    "CENTRE_DEPTH_SIGMA",
    "CENTRE_OFFSET_SCALE",
    "CentreOffset",
    "DEPTH_CORRELATION_PX",
    "DEPTH_NOISE",
    "DetectionPercepts",
    "DropReason",
    "Dropped",
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
        raise PerceptionError("K must be a camera matrix [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with "
                              f"fx, fy > 0, got {K.tolist()}")
    if not (MIN_FOCAL_PX <= K[0, 0] <= MAX_FOCAL_PX and MIN_FOCAL_PX <= K[1, 1] <= MAX_FOCAL_PX) or \
            np.any(np.abs(K[:2, 1:]) > MAX_FOCAL_PX):
        raise PerceptionError(f"K: focal lengths must lie in [{MIN_FOCAL_PX:g}, {MAX_FOCAL_PX:g}] px and "
                              f"the skew and principal point within {MAX_FOCAL_PX:g} px, got {K.tolist()}")
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


def centre_offset_of(name: str, value: object) -> CentreOffset:
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
        return {str(t): centre_offset_of(f"centre_offset[{t!r}]", d) for t, d in value.items()}
    one = centre_offset_of("centre_offset", value)
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


def touches_border(box: NDArray[np.float64], width: int, height: int) -> bool:
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


def visible_anchor(pts: NDArray[np.float64], up: NDArray[np.float64]
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
