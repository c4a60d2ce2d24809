"""Gaussian spheres (paper section 4.1) and the validation shared by all of radialopt.

A Gaussian sphere has a centre ``X`` (a model landmark), a radius ``r`` (the measured range
``|percept|``) and a standard deviation ``sigma`` of that range.  Its density at a point x is
``exp(-(|x - X| - r)^2 / (2 sigma^2))`` (eq. 11-12); the total density of several spheres
is the product (eq. 14), which in radial form is eq. 20.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from ._checks import (
    MAX_LENGTH,
    MAX_SIGMA,
    MIN_SIGMA_RELATIVE,
    instance,
    point3,
    real_array,
    real_scalar,
    sigma_range,
)
from .errors import (
    RadialArgumentError,
)
from .tolerances import TOLERANCES as TOLERANCES  # re-exported: radialopt.spheres.TOLERANCES
from .tolerances import Tolerances as Tolerances

_FLOATS = (float, np.float64)  # exact types of the fast path (not bool, not subclasses)
_F64 = np.dtype(np.float64)


@dataclass(frozen=True)
class GaussianSphere:
    """A sphere with a radially Gaussian density (paper eq. 12).

    Parameters
    ----------
    center : (3,) float
        Centre X, metres (a model landmark in the world frame).
    radius : float
        Radius r >= 0, metres (the measured range of the percept).
    sigma : float
        Standard deviation of the radius, > 0, metres (eq. 6).
    """

    center: NDArray[np.float64]
    radius: float
    sigma: float

    def __post_init__(self) -> None:
        # fast path: a float64 (3,) array or a list / tuple of three floats, and float radius and
        # sigma in range; anything else (or any value out of range) takes the checks below,
        # which raise the errors naming the argument and value
        c, radius, sigma = self.center, self.radius, self.sigma
        if type(radius) in _FLOATS and type(sigma) in _FLOATS and 0.0 <= radius <= MAX_LENGTH \
                and 0.0 < sigma <= MAX_SIGMA:
            if type(c) is np.ndarray and c.dtype == _F64 and c.shape == (3,):
                center = c.copy()
            elif type(c) in (list, tuple) and len(c) == 3 and all(type(v) in _FLOATS for v in c):
                center = np.array(c, dtype=np.float64)
            else:
                center = None
            if center is not None:
                x, y, z = center.tolist()
                if -MAX_LENGTH <= x <= MAX_LENGTH and -MAX_LENGTH <= y <= MAX_LENGTH \
                        and -MAX_LENGTH <= z <= MAX_LENGTH:
                    center.flags.writeable = False
                    object.__setattr__(self, "center", center)
                    object.__setattr__(self, "radius", float(radius))
                    object.__setattr__(self, "sigma", float(sigma))
                    return
        center = point3("center", self.center)
        radius = real_scalar("radius", self.radius)
        sigma = real_scalar("sigma", self.sigma)
        if radius < 0:
            raise RadialArgumentError(f"radius = {radius!r} must be >= 0")
        if sigma <= 0:
            raise RadialArgumentError(f"sigma = {sigma!r} must be > 0")
        radius = real_scalar("radius", radius, max_abs=MAX_LENGTH)
        sigma = real_scalar("sigma", sigma, max_abs=MAX_SIGMA)
        center.setflags(write=False)
        object.__setattr__(self, "center", center)
        object.__setattr__(self, "radius", radius)
        object.__setattr__(self, "sigma", sigma)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, GaussianSphere):
            return NotImplemented
        return (
            bool(np.array_equal(self.center, other.center))
            and self.radius == other.radius
            and self.sigma == other.sigma
        )

    def __hash__(self) -> int:
        return hash((tuple(self.center.tolist()), self.radius, self.sigma))

    def with_radius(self, radius: float) -> GaussianSphere:
        """The same sphere with another radius (an adjusted configuration)."""
        return GaussianSphere(self.center, radius, self.sigma)

    def density(self, x: ArrayLike) -> NDArray[np.float64] | float:
        """Eq. 12 at points ``x`` of shape (3,) or (k, 3)."""
        return density(self, x)

    def conformal(self) -> NDArray[np.float64]:
        """The conformal 5-vector of this sphere, see :func:`conformal_sphere`."""
        return conformal_sphere(self.center, self.radius)


def as_points(x: ArrayLike, name: str = "x") -> tuple[NDArray[np.float64], bool]:
    """Validate points of shape (3,) or (k, 3); return them as (k, 3) and a 'was single' flag."""
    arr = real_array(name, x, ndim=(1, 2))
    single = arr.ndim == 1
    pts = arr.reshape(1, -1) if single else arr
    if pts.shape[1] != 3 or pts.shape[0] == 0:
        raise RadialArgumentError(f"{name} must have shape (3,) or (k, 3) with k >= 1, got shape {arr.shape}")
    return pts, single


def sphere_arrays(
    spheres: Sequence[GaussianSphere],
    min_count: int = 2,
    tol: Tolerances = TOLERANCES,
    check_centers: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Stack spheres into ``centers (n, 3)``, ``radii (n,)``, ``sigmas (n,)``.

    Raises
    ------
    RadialError
        - Fewer than ``min_count`` spheres.
        - Two centres closer than ``tol.coincident`` (when ``check_centers``; callers that
          compute the pair distances anyway check them there).
    """
    if (isinstance(spheres, (str, bytes, GaussianSphere)) or not isinstance(spheres, Iterable)
            or (isinstance(spheres, np.ndarray) and spheres.ndim == 0)):
        raise RadialArgumentError(
            f"spheres must be a sequence of GaussianSphere, got {type(spheres).__name__}")
    spheres = list(spheres)
    for i, s in enumerate(spheres):
        if not isinstance(s, GaussianSphere):
            raise RadialArgumentError(f"spheres[{i}] must be a GaussianSphere, got {type(s).__name__}")
    if len(spheres) < min_count:
        raise RadialArgumentError(f"need at least {min_count} spheres, got {len(spheres)}")
    centers = np.array([s.center for s in spheres], dtype=np.float64).reshape(-1, 3)
    radius_list = [s.radius for s in spheres]
    sigma_list = [s.sigma for s in spheres]
    radii = np.array(radius_list, dtype=np.float64)
    sigmas = np.array(sigma_list, dtype=np.float64)
    if len(spheres):
        scale = max(float(np.abs(centers).max()), max(radius_list))
        floor, ceiling = _sigma_bounds(scale)
        if not all(floor <= s <= ceiling for s in sigma_list):  # sigma_range names the first
            sigma_range("sigmas", sigmas, scale)
    if check_centers:
        check_distinct_centers(centers, tol)
    return centers, radii, sigmas


def checked_arrays(
    centers: ArrayLike, radii: ArrayLike, sigmas: ArrayLike, min_count: int = 2
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Check sphere data given as arrays: ``centers (n, 3)``, ``radii (n,)``, ``sigmas (n,)`` or a
    scalar sigma (broadcast); return float64 arrays ``(n, 3)``, ``(n,)``, ``(n,)``.

    The checks of :class:`GaussianSphere` and :func:`sphere_arrays` on every element (real,
    finite, magnitudes, radii >= 0, sigmas > 0 within the relative range of
    ``sigma_range``); errors name the argument, the index and the value
    (``"radii[2] = -1.0 must be >= 0"``).  Coincident centres are not tested here.  Float64
    arrays of the right shapes are checked in plain Python (a few microseconds at small n); any
    other input, or any value out of range, takes ``real_array``.

    Raises
    ------
    RadialError
        - Bad input, as above.
        - Fewer than ``min_count`` centres.
    """
    if (type(centers) is np.ndarray and type(radii) is np.ndarray and type(sigmas) is np.ndarray
            and centers.dtype == _F64 and radii.dtype == _F64 and sigmas.dtype == _F64
            and centers.ndim == 2 and centers.shape[1] == 3 and len(centers) >= min_count
            and radii.shape == (len(centers),) and sigmas.shape in (radii.shape, ())):
        flat = centers.ravel().tolist()
        rl = radii.tolist()
        sl = sigmas.tolist() if sigmas.ndim else [sigmas.item()]
        total = sum(flat) + sum(rl) + sum(sl)  # NaN or inf if any element is (all are <= 1e100)
        if math.isfinite(total):
            lo, hi, rmax = min(flat), max(flat), max(rl)
            scale = max(-lo, hi, rmax, 1.0)
            if -MAX_LENGTH <= lo and hi <= MAX_LENGTH and 0.0 <= min(rl) and rmax <= MAX_LENGTH \
                    and MIN_SIGMA_RELATIVE * scale <= min(sl) and max(sl) <= scale / MIN_SIGMA_RELATIVE:
                s = sigmas if sigmas.ndim else np.full(len(rl), sl[0])
                return centers, radii, s
    c = real_array("centers", centers, shape=(None, 3))
    if len(c) < min_count:
        raise RadialArgumentError(f"centers: need at least {min_count} spheres (rows), got {len(c)}")
    r = real_array("radii", radii, shape=(len(c),), like="centers")
    s = real_array("sigmas", sigmas, ndim=(0, 1), max_abs=MAX_SIGMA)
    if s.ndim == 0:
        s = np.full(len(c), float(s))
    if s.shape != r.shape:
        raise RadialArgumentError(f"sigmas must be a scalar or have shape ({len(c)},) like centers, got "
                                  f"shape {s.shape}")
    bad = np.flatnonzero(r < 0)
    if bad.size:
        raise RadialArgumentError(f"radii[{bad[0]}] = {float(r[bad[0]])!r} must be >= 0")
    sigma_range("sigmas", s, max(float(np.abs(c).max(initial=0.0)), float(r.max(initial=0.0))))
    return c, r, s


def _sigma_bounds(length_scale: float) -> tuple[float, float]:
    """The range ``sigma_range`` accepts at this length scale."""
    scale = max(float(length_scale), 1.0)
    return MIN_SIGMA_RELATIVE * scale, scale / MIN_SIGMA_RELATIVE


def check_distinct_centers(centers: NDArray[np.float64], tol: Tolerances = TOLERANCES) -> None:
    """Raise :class:`RadialError` naming the first pair of coincident centres."""
    n = len(centers)
    if n < 2:
        return
    # neighbour query, not an (n, n) distance matrix: memory linear in n
    pairs = cKDTree(centers).query_pairs(r=tol.coincident, output_type="ndarray")
    if len(pairs):
        i, j = (int(v) for v in pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))][0])
        dist = float(np.linalg.norm(centers[i] - centers[j]))
        raise RadialArgumentError(
            f"centres {i} and {j} coincide (centers[{i}] = {centers[i].tolist()}, centers[{j}] = "
            f"{centers[j].tolist()}, distance "
            f"{dist:.3g} <= {tol.coincident:g})"
        )


def make_spheres(
    centers: ArrayLike, radii: ArrayLike, sigmas: ArrayLike
) -> list[GaussianSphere]:
    """Build spheres from ``centers (n, 3)``, ``radii (n,)``, ``sigmas (n,)`` (a scalar broadcasts)."""
    c = real_array("centers", centers, shape=(None, 3))
    r = real_array("radii", radii, shape=(len(c),), like="centers")
    s = real_array("sigmas", sigmas, ndim=(0, 1), max_abs=MAX_SIGMA)
    s = np.broadcast_to(s, r.shape) if s.ndim == 0 else s
    if s.shape != r.shape:
        raise RadialArgumentError(f"sigmas must be a scalar or have shape ({len(c)},), got shape {s.shape}")
    bad = np.flatnonzero(r < 0)
    if bad.size:
        raise RadialArgumentError(f"radii[{bad[0]}] = {float(r[bad[0]])!r} must be >= 0")
    bad = np.flatnonzero(s <= 0)
    if bad.size:
        raise RadialArgumentError(f"sigmas[{bad[0]}] = {float(s[bad[0]])!r} must be > 0")
    return [GaussianSphere(ci, float(ri), float(si)) for ci, ri, si in zip(c, r, s, strict=True)]


def density(sphere: GaussianSphere, x: ArrayLike) -> NDArray[np.float64] | float:
    """Density of one Gaussian sphere at ``x`` (eq. 11-12), in (0, 1].

    ``x`` is a point (3,) -> float, or points (k, 3) -> (k,).
    """
    instance("sphere", sphere, GaussianSphere)
    pts, single = as_points(x)
    dev = np.linalg.norm(pts - sphere.center, axis=1) - sphere.radius
    out = np.exp(-0.5 * (dev / sphere.sigma) ** 2)
    return float(out[0]) if single else out


#: :func:`total_density` evaluates the points in chunks whose (points, spheres, 3) temporary holds
#: at most about this many floats (8 MB), so its memory is linear in the input.
DENSITY_CHUNK_ELEMENTS = 1_000_000


def total_density(spheres: Sequence[GaussianSphere], x: ArrayLike) -> NDArray[np.float64] | float:
    """Product density of several Gaussian spheres at ``x`` (eq. 14, radial form eq. 20)."""
    centers, radii, sigmas = sphere_arrays(spheres, min_count=1, check_centers=False)
    pts, single = as_points(x)
    # chunks of points keep the (points, spheres, 3) temporary near DENSITY_CHUNK_ELEMENTS floats
    step = max(int(DENSITY_CHUNK_ELEMENTS) // (3 * len(centers)), 1)
    out = np.empty(len(pts))
    for lo in range(0, len(pts), step):
        rx = np.linalg.norm(pts[lo:lo + step, None, :] - centers[None, :, :], axis=-1)
        out[lo:lo + step] = np.exp(-0.5 * np.sum(((rx - radii) / sigmas) ** 2, axis=1))
    return float(out[0]) if single else out


def radial_density(radii: ArrayLike, measured: ArrayLike, sigmas: ArrayLike) -> float:
    """Eq. 18/20 in radial space: ``exp(-1/2 |H (radii - measured)|^2)``, H = diag(1/sigma)."""
    x = real_array("radii", radii, ndim=(1,))
    m = real_array("measured", measured, shape=x.shape, like="radii")
    s = real_array("sigmas", sigmas, shape=x.shape, max_abs=MAX_SIGMA, like="radii")
    sigma_range("sigmas", s, max(float(np.abs(np.r_[x, m]).max(initial=0.0)), 1.0))
    z = (x - m) / s
    return float(np.exp(-0.5 * float(z @ z)))


# --- conformal model (docs/design.md#m1) ---------------------------------------------------
# A conformal vector is stored as the 5 coefficients (e1, e2, e3, e0, e_inf) with the metric
# e_i . e_i = 1, e0 . e0 = e_inf . e_inf = 0, e0 . e_inf = -1.
#: Largest magnitude of a conformal coordinate accepted (``|X|^2 / 2`` of a MAX_LENGTH point is 5e17).
CONFORMAL_MAX = 1e100

CONFORMAL_METRIC = np.array(
    [
        [1.0, 0, 0, 0, 0],
        [0, 1.0, 0, 0, 0],
        [0, 0, 1.0, 0, 0],
        [0, 0, 0, 0, -1.0],
        [0, 0, 0, -1.0, 0],
    ]
)


def conformal_sphere(center: ArrayLike, radius: float) -> NDArray[np.float64]:
    """Conformal 5-vector ``S = X + 1/2 (|X|^2 - r^2) e_inf + e0`` (eq. 4 with its squares).

    The paper's typesetting drops the squares; with them ``S1 . S2 = -1/2 (d^2 - r1^2 - r2^2)``
    where d is the distance between the centres.  ``radius**2`` may be negative for an
    imaginary sphere; pass ``radius = 1j * rho`` semantics through :func:`conformal_sphere_sq`.
    """
    x = point3("center", center)
    rad = real_scalar("radius", radius, max_abs=MAX_LENGTH)
    if rad < 0:
        raise RadialArgumentError(f"radius = {rad!r} must be >= 0 (an imaginary sphere goes through "
                                  "conformal_sphere_sq with a negative squared radius)")
    return conformal_sphere_sq(x, rad**2)


def conformal_sphere_sq(center: ArrayLike, radius_sq: float) -> NDArray[np.float64]:
    """Conformal sphere from its squared radius (negative for an imaginary sphere)."""
    x = np.asarray(center, dtype=np.float64)
    return np.array([x[0], x[1], x[2], 1.0, 0.5 * (x @ x - radius_sq)])


def conformal_inner(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64] | float:
    """Inner product of conformal vectors (last axis of length 5)."""
    a = real_array("a", a, max_abs=CONFORMAL_MAX)
    b = real_array("b", b, max_abs=CONFORMAL_MAX)
    for name, arr in (("a", a), ("b", b)):
        if arr.ndim == 0 or arr.shape[-1] != 5:
            raise RadialArgumentError(f"{name} must have a last axis of length 5, got shape {arr.shape}")
    try:
        np.broadcast_shapes(a.shape[:-1], b.shape[:-1])
    except ValueError as exc:
        raise RadialArgumentError(f"a and b do not broadcast: shapes {a.shape} and {b.shape}") from exc
    out = np.einsum("...i,ij,...j->...", a, CONFORMAL_METRIC, b)
    return float(out) if np.ndim(out) == 0 else out
