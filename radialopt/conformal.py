"""The meet of spheres in the conformal model, computed with plain linear algebra.

Spheres are conformal 5-vectors ``S = X + 1/2 (|X|^2 - r^2) e_inf + e0`` (paper eq. 4 with
its squares, docs/design.md#m1); the squared radius may be negative (an imaginary sphere).
The meet of two spheres is a :class:`Circle`, of three a :class:`PointPair`, of four a
:class:`Point` (paper section 2.3, Fig. 6).  Instead of the outer-product algebra the meet is
computed from radical planes: for spheres i and j, ``S_i - S_j`` (both normalised to an
``e0`` coefficient of one) is the plane ``2 (X_j - X_i) . x = p_j - p_i`` with the power
``p = |X|^2 - r^2``; every point of the meet lies on it.

Precision: every meet is computed in a frame whose origin is the centroid of the centres
(then translated back), so landmarks far from the origin keep their relative precision.
Spheres given as 5-vectors carry ``|X|^2 - r^2`` in one coefficient, so their squared radius
is only known to about ``eps |X|^2``; pass :class:`~radialopt.spheres.GaussianSphere` objects
for full precision far from the origin.

Classification uses :class:`MeetTolerances` (relative to the squared size of the
configuration).  Degenerate centre configurations return a status (``"coincident"``,
``"collinear"``, ``"coplanar"``) with NaN coordinates instead of a meaningless point.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields
from enum import IntEnum
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._checks import MAX_LENGTH, instance, real_array
from .errors import (
    RadialArgumentError,
)
from .spheres import CONFORMAL_MAX, GaussianSphere
from .tolerances import E0_RELATIVE, MEET_TOLERANCES, TINY, MeetTolerances

__all__ = [
    "Circle",
    "CircleBatch",
    "MeetStatus",
    "MeetTolerances",
    "MEET_TOLERANCES",
    "Point",
    "PointBatch",
    "PointPair",
    "PointPairBatch",
    "as_conformal",
    "meet",
    "meet2_batch",
    "meet3_batch",
    "meet4_batch",
]


class MeetStatus(IntEnum):
    """Status codes of a meet (batched functions return these as ``int8``).

    ``REAL``: a real circle / two distinct points / four spheres sharing the point.
    ``TANGENT``: a circle or point pair of zero radius (one point, the spheres touch).
    ``IMAGINARY``: no real intersection (negative squared radius); coordinates are those of
    the real carrier (circle centre, or the foot point of the point pair, twice).
    ``INEXACT``: four spheres whose radical centre is not on them (residual != 0).
    ``COINCIDENT``: two centres coincide; ``COLLINEAR``/``COPLANAR``: the centres span too
    few dimensions for the meet to be a point pair / a point.  Coordinates are NaN.
    """

    REAL = 0
    TANGENT = 1
    IMAGINARY = 2
    INEXACT = 3
    COINCIDENT = 4
    COLLINEAR = 5
    COPLANAR = 6

    @property
    def label(self) -> str:
        """Lower-case name used as the ``status`` string of the scalar primitives."""
        return self.name.lower()


# --- input -------------------------------------------------------------------------------

def as_conformal(sphere: GaussianSphere | ArrayLike, name: str = "sphere"
                 ) -> tuple[NDArray[np.float64], float]:
    """Centre and squared radius of a GaussianSphere or a conformal 5-vector.

    Parameters
    ----------
    sphere : GaussianSphere or (5,) float
        A conformal vector in the basis ``(e1, e2, e3, e0, e_inf)``; any non-zero multiple of
        a sphere is accepted (it is normalised by its ``e0`` coefficient).

    Returns
    -------
    center : (3,) float
    radius_sq : float
        May be negative (imaginary sphere).

    Raises
    ------
    RadialError
        - Not a finite 5-vector.
        - The ``e0`` coefficient is zero: a plane or the point at infinity, not a sphere.
    """
    if isinstance(sphere, GaussianSphere):
        return np.array(sphere.center, dtype=np.float64), sphere.radius**2
    v = real_array(name, sphere, max_abs=CONFORMAL_MAX)
    if v.shape != (5,):
        raise RadialArgumentError(f"{name} must be a GaussianSphere or a conformal 5-vector, got shape "
                                  f"{v.shape}: {v!r:.200}")
    w0 = v[3]
    if abs(w0) <= TINY or abs(w0) <= E0_RELATIVE * np.max(np.abs(v)):
        raise RadialArgumentError(f"{name} = conformal vector {v.tolist()} has e0 coefficient {w0!r}: "
                                  "a plane or the point at infinity, not a sphere")
    center = v[:3] / w0
    radius_sq = float(center @ center - 2.0 * v[4] / w0)
    if not (np.all(np.abs(center) <= MAX_LENGTH) and abs(radius_sq) <= MAX_LENGTH**2):
        raise RadialArgumentError(f"{name} = {v.tolist()} has centre {center.tolist()} and squared radius "
                                  f"{radius_sq:.3g} beyond the usable magnitude {MAX_LENGTH:g} m")
    return center, radius_sq


# --- primitives --------------------------------------------------------------------------

@dataclass(frozen=True)
class Circle:
    """The meet of two spheres (may be imaginary).

    Attributes
    ----------
    center : (3,) float
        Centre of the circle (on the line of the sphere centres); NaN if ``coincident``.
    normal : (3,) float
        Unit normal of the circle's plane (from the first centre to the second).
    radius_sq : float
        Squared radius; negative for an imaginary circle.
    status : str
        ``"real"``, ``"tangent"``, ``"imaginary"`` or ``"coincident"``.
    message : str
        Human-readable explanation of a non-real status.
    """

    center: NDArray[np.float64]
    normal: NDArray[np.float64]
    radius_sq: float
    status: str
    message: str = ""

    @property
    def radius(self) -> float:
        """Radius (0 for tangent, NaN if imaginary or degenerate)."""
        if self.status == "tangent":
            return 0.0
        return float(np.sqrt(self.radius_sq)) if self.radius_sq >= 0 else float("nan")


@dataclass(frozen=True)
class PointPair:
    """The meet of three spheres: two points, one (tangent) or none (imaginary).

    Attributes
    ----------
    points : (2, 3) float
        The two points ``center -+ sqrt(half_distance_sq) * axis``.  Tangent: the same point
        twice; imaginary: the foot point twice (the real point closest to a meet, on the
        plane of the centres); NaN when the centres are collinear or coincide.
    center : (3,) float
        Midpoint of the pair, on the plane of the centres.
    axis : (3,) float
        Unit normal of the plane of the centres (right-handed from the sphere order).
    half_distance_sq : float
        Squared half distance between the points; negative when imaginary.
    status : str
        ``"real"``, ``"tangent"``, ``"imaginary"``, ``"collinear"`` or ``"coincident"``.
    message : str
    """

    points: NDArray[np.float64]
    center: NDArray[np.float64]
    axis: NDArray[np.float64]
    half_distance_sq: float
    status: str
    message: str = ""


@dataclass(frozen=True)
class Point:
    """The meet of four spheres: their radical centre.

    Attributes
    ----------
    position : (3,) float
        The radical centre, the point with equal power ``|x - X_i|^2 - r_i^2`` with respect
        to all four spheres; NaN when the centres are coplanar, collinear or coincide.
    residual : float
        That common power, rho^2: zero when the four spheres share the point; otherwise the
        squared radius of the sphere orthogonal to all four (negative: the point lies inside
        them).
    status : str
        ``"real"`` (shared within tolerance), ``"inexact"``, ``"coplanar"``, ``"collinear"``
        or ``"coincident"``.
    message : str
    """

    position: NDArray[np.float64]
    residual: float
    status: str
    message: str = ""


@dataclass(frozen=True)
class CircleBatch:
    """Batched :class:`Circle`: ``center (k, 3)``, ``normal (k, 3)``, ``radius_sq (k,)``,
    ``status (k,) int8`` (:class:`MeetStatus` codes)."""

    center: NDArray[np.float64]
    normal: NDArray[np.float64]
    radius_sq: NDArray[np.float64]
    status: NDArray[np.int8]


@dataclass(frozen=True)
class PointPairBatch:
    """Batched :class:`PointPair`: ``points (k, 2, 3)``, ``center (k, 3)``, ``axis (k, 3)``,
    ``half_distance_sq (k,)``, ``status (k,) int8``."""

    points: NDArray[np.float64]
    center: NDArray[np.float64]
    axis: NDArray[np.float64]
    half_distance_sq: NDArray[np.float64]
    status: NDArray[np.int8]


@dataclass(frozen=True)
class PointBatch:
    """Batched :class:`Point`: ``position (k, 3)``, ``residual (k,)``, ``status (k,) int8``."""

    position: NDArray[np.float64]
    residual: NDArray[np.float64]
    status: NDArray[np.int8]


# --- batched meets -----------------------------------------------------------------------

def _check_batch(centers: ArrayLike, radii_sq: ArrayLike, m: int) -> tuple[NDArray, NDArray]:
    c = real_array("centers", centers, shape=("k", m, 3))
    r2 = real_array("radii_sq", radii_sq, shape=c.shape[:2], max_abs=MAX_LENGTH**2)
    for name, arr in (("centers", c), ("radii_sq", r2)):
        if not np.all(np.isfinite(arr)):
            raise RadialArgumentError(f"{name} must be finite; first bad index "
                                      f"{np.argwhere(~np.isfinite(arr))[0].tolist()}")
    return c, r2


def _centred(c: NDArray, r2: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Translate each instance so the centroid of its centres is the origin.

    Returns the centroids ``(k, 3)``, centred centres ``(k, m, 3)``, powers ``(k, m)`` in the
    centred frame and the configuration size ``L (k,)``.
    """
    origin = c.mean(axis=1)
    cc = c - origin[:, None, :]
    power = np.einsum("kmi,kmi->km", cc, cc) - r2
    size = np.maximum(np.linalg.norm(cc, axis=2).max(axis=1), np.sqrt(np.abs(r2)).max(axis=1))
    return origin, cc, power, np.maximum(size, np.finfo(float).tiny)


def _min_pair_distance(cc: NDArray) -> NDArray:
    m = cc.shape[1]
    iu, ju = np.triu_indices(m, 1)
    return np.linalg.norm(cc[:, iu] - cc[:, ju], axis=2).min(axis=1)


#: The batched meets work on at most this many instances at a time, so their temporaries (a few
#: dozen floats per instance) stay bounded whatever k is; the outputs are filled in place.
MEET_CHUNK = 100_000


def _chunked(rows: Callable[[NDArray, NDArray, MeetTolerances], Any], c: NDArray, r2: NDArray,
             tol: MeetTolerances) -> Any:
    """``rows(c, r2, tol)`` over slices of :data:`MEET_CHUNK` instances, written into outputs
    allocated once (memory: the outputs plus one chunk of temporaries)."""
    k = c.shape[0]
    step = max(int(MEET_CHUNK), 1)
    if k <= step:
        return rows(c, r2, tol)
    first = rows(c[:step], r2[:step], tol)
    names = [f.name for f in fields(first)]
    out = {}
    for name in names:
        part = getattr(first, name)
        out[name] = np.empty((k,) + part.shape[1:], dtype=part.dtype)
        out[name][:step] = part
    for lo in range(step, k, step):
        part = rows(c[lo:lo + step], r2[lo:lo + step], tol)
        for name in names:
            out[name][lo:lo + step] = getattr(part, name)
    return type(first)(**out)


def meet2_batch(centers: ArrayLike, radii_sq: ArrayLike,
                tol: MeetTolerances = MEET_TOLERANCES) -> CircleBatch:
    """Circles of k sphere pairs.

    Parameters
    ----------
    centers : (k, 2, 3) float
    radii_sq : (k, 2) float
        Squared radii (negative allowed).
    tol : MeetTolerances

    Returns
    -------
    CircleBatch
    """
    instance("tol", tol, MeetTolerances)
    c, r2 = _check_batch(centers, radii_sq, 2)
    return _chunked(_meet2_rows, c, r2, tol)


def _meet2_rows(c: NDArray, r2: NDArray, tol: MeetTolerances) -> CircleBatch:
    origin, cc, _, size = _centred(c, r2)
    d = cc[:, 1] - cc[:, 0]
    delta = np.linalg.norm(d, axis=1)
    coincident = delta <= tol.coincident * size
    safe = np.where(coincident, 1.0, delta)
    normal = d / safe[:, None]
    # distance of the radical plane from the first centre along the normal
    t = (delta**2 + r2[:, 0] - r2[:, 1]) / (2.0 * safe)
    center = origin + cc[:, 0] + t[:, None] * normal
    rsq = r2[:, 0] - t**2
    # factored form, free of cancellation near tangency, when both spheres are real
    both_real = (r2[:, 0] >= 0) & (r2[:, 1] >= 0)
    r0, r1 = np.sqrt(np.maximum(r2[:, 0], 0)), np.sqrt(np.maximum(r2[:, 1], 0))
    factored = (r0 + r1 - delta) * (r0 + r1 + delta) * (delta - r0 + r1) * (delta + r0 - r1) / (
        4.0 * safe**2)
    rsq = np.where(both_real, factored, rsq)
    status = _classify(rsq, size, tol, MeetStatus.REAL)
    status[coincident] = MeetStatus.COINCIDENT
    center[coincident] = np.nan
    normal[coincident] = np.nan
    rsq[coincident] = np.nan
    return CircleBatch(center, normal, rsq, status)


def meet3_batch(centers: ArrayLike, radii_sq: ArrayLike,
                tol: MeetTolerances = MEET_TOLERANCES) -> PointPairBatch:
    """Point pairs of k sphere triples.

    The two radical planes through the first sphere meet in a line normal to the plane of
    the centres; its foot on that plane is the midpoint of the pair.

    Parameters
    ----------
    centers : (k, 3, 3) float
    radii_sq : (k, 3) float
    tol : MeetTolerances

    Returns
    -------
    PointPairBatch
        ``points[:, 0]`` lies on the ``-axis`` side, ``points[:, 1]`` on the ``+axis`` side.
    """
    instance("tol", tol, MeetTolerances)
    c, r2 = _check_batch(centers, radii_sq, 3)
    return _chunked(_meet3_rows, c, r2, tol)


def _meet3_rows(c: NDArray, r2: NDArray, tol: MeetTolerances) -> PointPairBatch:
    origin, cc, power, size = _centred(c, r2)
    a = cc[:, 1] - cc[:, 0]
    b = cc[:, 2] - cc[:, 0]
    n = np.cross(a, b)
    nn = np.einsum("ki,ki->k", n, n)
    la, lb = np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1)
    coincident = _min_pair_distance(cc) <= tol.coincident * size
    collinear = ~coincident & (np.sqrt(nn) <= tol.collinear * la * lb)
    bad = coincident | collinear
    nn_safe = np.where(bad, 1.0, nn)
    # foot point x0 in the plane of the centres (which contains the origin, the centroid):
    # a . x0 = (p1 - p0)/2 and b . x0 = (p2 - p0)/2, solved with x0 = alpha (b x n) + beta (n x a)
    ha = 0.5 * (power[:, 1] - power[:, 0])
    hb = 0.5 * (power[:, 2] - power[:, 0])
    x0 = (ha[:, None] * np.cross(b, n) + hb[:, None] * np.cross(n, a)) / nn_safe[:, None]
    axis = n / np.sqrt(nn_safe)[:, None]
    diff = x0[:, None, :] - cc
    hsq = np.mean(r2 - np.einsum("kmi,kmi->km", diff, diff), axis=1)
    status = _classify(hsq, size, tol, MeetStatus.REAL)
    half = np.sqrt(np.where(status == MeetStatus.REAL, hsq, 0.0))
    centre = origin + x0
    points = centre[:, None, :] + np.array([-1.0, 1.0])[None, :, None] * (half[:, None] * axis)[
        :, None, :]
    status[collinear] = MeetStatus.COLLINEAR
    status[coincident] = MeetStatus.COINCIDENT
    for arr in (points, centre, axis, hsq):
        arr[bad] = np.nan
    return PointPairBatch(points, centre, axis, hsq, status)


def meet4_batch(centers: ArrayLike, radii_sq: ArrayLike,
                tol: MeetTolerances = MEET_TOLERANCES) -> PointBatch:
    """Radical centres of k sphere quadruples (a 3x3 linear solve each).

    Parameters
    ----------
    centers : (k, 4, 3) float
    radii_sq : (k, 4) float
    tol : MeetTolerances

    Returns
    -------
    PointBatch
        ``residual`` is the common power rho^2 of the radical centre (zero iff the four
        spheres share it).
    """
    instance("tol", tol, MeetTolerances)
    c, r2 = _check_batch(centers, radii_sq, 4)
    return _chunked(_meet4_rows, c, r2, tol)


def _meet4_rows(c: NDArray, r2: NDArray, tol: MeetTolerances) -> PointBatch:
    origin, cc, power, size = _centred(c, r2)
    sv = np.linalg.svd(cc, compute_uv=False)  # (k, 3)
    smax = np.maximum(sv[:, 0], np.finfo(float).tiny)
    coincident = _min_pair_distance(cc) <= tol.coincident * size
    collinear = ~coincident & (sv[:, 1] <= tol.collinear * smax)
    coplanar = ~coincident & ~collinear & (sv[:, 2] <= tol.coplanar * smax)
    bad = coincident | collinear | coplanar
    M = 2.0 * (cc[:, 1:] - cc[:, :1])
    rhs = power[:, 1:] - power[:, :1]
    M[bad] = np.eye(3)
    rhs[bad] = 0.0
    x = np.linalg.solve(M, rhs[..., None])[..., 0]
    diff = x[:, None, :] - cc
    rho_sq = np.mean(np.einsum("kmi,kmi->km", diff, diff) - r2, axis=1)
    status = np.where(np.abs(rho_sq) <= tol.tangent * size**2, MeetStatus.REAL,
                      MeetStatus.INEXACT).astype(np.int8)
    status[coplanar] = MeetStatus.COPLANAR
    status[collinear] = MeetStatus.COLLINEAR
    status[coincident] = MeetStatus.COINCIDENT
    position = origin + x
    position[bad] = np.nan
    rho_sq[bad] = np.nan
    return PointBatch(position, rho_sq, status)


def _classify(rsq: NDArray, size: NDArray, tol: MeetTolerances, real: MeetStatus) -> NDArray:
    zero = np.abs(rsq) <= tol.tangent * size**2
    out = np.where(rsq > 0, real, MeetStatus.IMAGINARY)
    out = np.where(zero, MeetStatus.TANGENT, out)
    return out.astype(np.int8)


# --- scalar meet -------------------------------------------------------------------------

_MESSAGES = {
    MeetStatus.REAL: "",
    MeetStatus.TANGENT: "the spheres touch: the meet is a single point",
    MeetStatus.IMAGINARY: "the spheres do not intersect: the meet is imaginary (coordinates are "
                          "those of its real carrier)",
    MeetStatus.INEXACT: "the four spheres share no point: the radical centre has power "
                        "(residual) {residual:.3g}",
    MeetStatus.COINCIDENT: "two sphere centres coincide: the meet is not defined",
    MeetStatus.COLLINEAR: "the centres are collinear: the meet is a circle (or empty), not {what}",
    MeetStatus.COPLANAR: "the four centres are coplanar: the radical centre is not defined; use "
                         "the point pair of three spheres",
}


def _message(code: int, **kw: object) -> str:
    return _MESSAGES[MeetStatus(code)].format(**kw)


def meet(*spheres: GaussianSphere | ArrayLike,
         tol: MeetTolerances = MEET_TOLERANCES) -> Circle | PointPair | Point:
    """The meet (intersection) of two, three or four spheres (paper section 2.3, Fig. 6).

    Parameters
    ----------
    *spheres : GaussianSphere or (5,) float conformal vectors, 2 to 4 of them
        Squared radii of conformal vectors may be negative (imaginary spheres).
    tol : MeetTolerances

    Returns
    -------
    Circle (2 spheres) | PointPair (3 spheres) | Point (4 spheres)

    Raises
    ------
    RadialError
        - Fewer than two or more than four spheres.
        - A sphere that is not a valid sphere.
    """
    instance("tol", tol, MeetTolerances)
    if len(spheres) < 2:
        raise RadialArgumentError(f"the meet needs 2 to 4 spheres, got {len(spheres)}")
    if len(spheres) > 4:
        raise RadialArgumentError(f"the meet takes 2 to 4 spheres, got {len(spheres)}")
    parts = [as_conformal(s, f"spheres[{i}]") for i, s in enumerate(spheres)]
    c = np.stack([p[0] for p in parts])[None]
    r2 = np.array([p[1] for p in parts])[None]
    if len(parts) == 2:
        cb = meet2_batch(c, r2, tol)
        code = int(cb.status[0])
        return Circle(cb.center[0], cb.normal[0], float(cb.radius_sq[0]),
                      MeetStatus(code).label, _message(code))
    if len(parts) == 3:
        pb = meet3_batch(c, r2, tol)
        code = int(pb.status[0])
        return PointPair(pb.points[0], pb.center[0], pb.axis[0], float(pb.half_distance_sq[0]),
                         MeetStatus(code).label, _message(code, what="a point pair"))
    qb = meet4_batch(c, r2, tol)
    code = int(qb.status[0])
    residual = float(qb.residual[0])
    return Point(qb.position[0], residual, MeetStatus(code).label,
                 _message(code, residual=residual, what="a point"))

