"""Image-to-space uncertainty (paper section 3.1, eqs. 6-8) and its stereo generalisation.

The paper's model ``sigma = rho^2 / depth_factor`` (eq. 6) with ``rho`` the depth along the
viewing direction (eq. 7); the disparity ``d = f b / rho`` (eq. 8); the pixel footprint
``A = rho^2 tan(theta_h / h) tan(theta_v / v)``. Beyond the paper: the full 3x3 covariance of a
triangulated point from the Jacobian of triangulation w.r.t. the four pixel coordinates, and
the fusion bandwidth from a class model's vertices.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._checks import integer, real_array, real_scalar
from ..errors import PerceptionError

if TYPE_CHECKING:
    from .stereo import StereoRig


def _finite(name: str, value: ArrayLike) -> NDArray[np.float64]:
    return real_array(name, value)


def _positive(name: str, value: ArrayLike) -> NDArray[np.float64]:
    arr = _finite(name, value)
    if arr.ndim == 0:
        if not arr > 0:
            raise PerceptionError(f"{name} must be > 0, got {float(arr)!r}")
        return arr
    bad = np.argwhere(~(arr > 0))
    if bad.size:
        idx = tuple(bad[0])
        raise PerceptionError(f"{name}[{', '.join(map(str, idx))}] must be > 0, got {arr[idx]!r}")
    return arr


def _non_negative(name: str, value: ArrayLike) -> NDArray[np.float64]:
    arr = _finite(name, value)
    bad = np.argwhere(~(np.atleast_1d(arr) >= 0))
    if bad.size:
        if arr.ndim == 0:
            raise PerceptionError(f"{name} must be >= 0, got {float(arr)!r}")
        idx = tuple(bad[0])
        raise PerceptionError(f"{name}[{', '.join(map(str, idx))}] must be >= 0, got {arr[idx]!r}")
    return arr


def _scalar_or_vector(name: str, arr: NDArray[np.float64]) -> NDArray[np.float64]:
    if arr.ndim > 1:
        raise PerceptionError(f"{name} must be a scalar or shape (N,), got shape {arr.shape}")
    return arr


def _result(what: str, out: NDArray[np.float64], name: str, arg: NDArray[np.float64]) -> NDArray[np.float64]:
    """``out`` if finite, else an error naming the first argument element whose result overflows."""
    bad = ~np.isfinite(np.atleast_1d(out))
    if np.any(bad):
        idx = tuple(np.argwhere(bad)[0]) if np.ndim(out) else ()
        j = idx[: arg.ndim] if arg.ndim else ()
        where = "[" + ", ".join(map(str, j)) + "]" if j else ""
        raise PerceptionError(f"{what} overflows for {name}{where} = {arg[j]!r}")
    return out


def _out(x: NDArray[np.float64]) -> NDArray[np.float64] | float:
    return float(x) if x.ndim == 0 else x


def perception_depth(
    points: ArrayLike, camera_center: ArrayLike, viewing_direction: ArrayLike
) -> NDArray[np.float64] | float:
    """Perception depth ``rho = (x - C_L) @ e_d`` (eq. 7).

    Parameters
    ----------
    points : (3,) or (N, 3) float
        Points ``x``.
    camera_center : (3,) float
        Camera centre ``C_L`` in the same frame.
    viewing_direction : (3,) float
        Viewing direction ``e_d`` (normalised here; must be non-zero).

    Returns
    -------
    float or (N,) float
    """
    X = _finite("points", points)
    if X.shape[-1:] != (3,) or X.ndim > 2:
        raise PerceptionError(f"points must have shape (3,) or (N, 3), got shape {X.shape}")
    C = real_array("camera_center", camera_center, (3,))
    e = real_array("viewing_direction", viewing_direction, (3,))
    top = float(np.max(np.abs(e)))
    if top == 0:
        raise PerceptionError(f"viewing_direction must be non-zero, got {e.tolist()}")
    u = e / top
    u = u / np.linalg.norm(u)
    with np.errstate(over="ignore", invalid="ignore"):
        rho = (X - C) @ u
    return _out(_result("the perception depth", rho, "points", X))


def depth_sigma(
    rho: ArrayLike, depth_factor: float, *, min_sigma: float = 0.0
) -> NDArray[np.float64] | float:
    """Standard deviation of a percept at perception depth ``rho``: ``rho^2 / depth_factor`` (eq. 6).

    Parameters
    ----------
    rho : float or (N,) float
        Perception depth, metres (finite, > 0; >= 0 when ``min_sigma > 0``).
    depth_factor : float
        The paper's empirical factor (its ζ), > 0, in 1/metres.
    min_sigma : float
        Floor of the result, metres (finite, >= 0): ``max(min_sigma, rho^2 / depth_factor)``.
        The paper has none; simulations use one so that near percepts keep a usable sigma
        (docs/design.md#perception).
        With a positive floor a depth of 0 is allowed (its sigma is the floor).

    Returns
    -------
    float or (N,) float
        A float for a scalar ``rho``, else an array of the shape of ``rho``.

    Raises
    ------
    PerceptionError
        - A depth that is not > 0 (not >= 0 with a positive floor), a ``depth_factor`` <= 0,
          a negative ``min_sigma``.
        - A NaN or infinite input, or ``rho^2 / depth_factor`` that overflows.
    """
    floor = real_scalar("min_sigma", min_sigma, minimum=0.0)
    if floor > 0:
        r = _scalar_or_vector("rho", _non_negative("rho", rho))
    else:
        r = _scalar_or_vector("rho", _positive("rho", rho))
    df = real_scalar("depth_factor", depth_factor, positive=True)
    with np.errstate(over="ignore"):
        out = r**2 / df
    if floor > 0:
        out = np.maximum(floor, out)
    return _out(_result("rho**2 / depth_factor", out, "rho", r))


def disparity(rho: ArrayLike, focal_px: float, baseline: float) -> NDArray[np.float64] | float:
    """Disparity ``d = f b / rho`` in pixels of a point at depth ``rho`` (eq. 8).

    Parameters
    ----------
    rho : float or (N,) float
        Depth, metres (> 0).
    focal_px : float
        Focal length, pixels (> 0).
    baseline : float
        Baseline ``|C_L - C_R|``, metres (> 0).
    """
    r = _scalar_or_vector("rho", _positive("rho", rho))
    f = real_scalar("focal_px", focal_px, positive=True)
    b = real_scalar("baseline", baseline, positive=True)
    with np.errstate(over="ignore"):
        out = (f * b) / r
    if not np.isfinite(f * b):
        raise PerceptionError(f"focal_px * baseline overflows: focal_px = {f!r}, baseline = {b!r}")
    return _out(_result("focal_px * baseline / rho", out, "rho", r))


def pixel_footprint(
    rho: ArrayLike, hfov: float, vfov: float, width: int, height: int
) -> NDArray[np.float64] | float:
    """Area imaged into one pixel at depth ``rho``: ``rho^2 tan(hfov / width) tan(vfov / height)``.

    The ``A_i`` formula of section 3.1; angles in radians, image size in pixels.
    """
    r = _scalar_or_vector("rho", _positive("rho", rho))
    h = real_scalar("hfov", hfov, positive=True)
    v = real_scalar("vfov", vfov, positive=True)
    if h >= np.pi:
        raise PerceptionError(f"hfov must lie in (0, pi) radians, got {h!r}")
    if v >= np.pi:
        raise PerceptionError(f"vfov must lie in (0, pi) radians, got {v!r}")
    w = integer("width", width, minimum=1, maximum=10**9)
    hh = integer("height", height, minimum=1, maximum=10**9)
    with np.errstate(over="ignore"):
        out = r**2 * (np.tan(h / w) * np.tan(v / hh))
    return _out(_result("the pixel footprint", out, "rho", r))


def triangulation_jacobian(
    rig: StereoRig, uv_left: ArrayLike, uv_right: ArrayLike, step: float = 1e-3
) -> NDArray[np.float64]:
    """Jacobian of :meth:`StereoRig.triangulate` w.r.t. ``(u_L, v_L, u_R, v_R)``.

    Central differences with ``step`` pixels, all points and coordinates in one
    triangulation call.

    Returns
    -------
    (N, 3, 4) float
    """
    u1, u2 = _matched_pixels(rig, uv_left, uv_right)
    h = real_scalar("step", step, positive=True)
    if not 1e-9 <= h <= 10.0:
        raise PerceptionError(f"step must lie in [1e-9, 10] pixels, got {h!r}")
    n = u1.shape[0]
    base = np.hstack([u1, u2])  # (N, 4)
    # 8 perturbed copies: +h and -h on each of the 4 coordinates
    delta = np.vstack([np.eye(4) * h, -np.eye(4) * h])  # (8, 4)
    pert = (base[None, :, :] + delta[:, None, :]).reshape(-1, 4)
    X = rig.triangulate(pert[:, :2], pert[:, 2:]).reshape(8, n, 3)
    J = (X[:4] - X[4:]) / (2.0 * h)  # (4, N, 3)
    return np.transpose(J, (1, 2, 0))


def _matched_pixels(rig: object, uv_left: ArrayLike, uv_right: ArrayLike
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(N, 2)`` left and right pixels of ``rig`` (a StereoRig), checked and of equal shape."""
    from .stereo import _points, as_stereo_rig

    as_stereo_rig(rig)
    u1 = _points("uv_left", uv_left, 2)
    u2 = _points("uv_right", uv_right, 2)
    if u1.shape != u2.shape:
        raise PerceptionError(f"uv_left and uv_right must have the same shape, got {u1.shape} and {u2.shape}")
    return u1, u2


def triangulation_covariance(
    rig: StereoRig, uv_left: ArrayLike, uv_right: ArrayLike, pixel_sigma: float | ArrayLike = 0.5
) -> NDArray[np.float64]:
    """Covariance of triangulated points from isotropic pixel noise: ``J diag(pixel_sigma^2) J^T``.

    Parameters
    ----------
    rig : StereoRig
    uv_left, uv_right : (N, 2) float
        Matched pixels.
    pixel_sigma : float or (4,) float
        Standard deviation of ``(u_L, v_L, u_R, v_R)``, pixels (> 0).

    Returns
    -------
    (N, 3, 3) float
        Covariances in the left camera frame.
    """
    s = _positive("pixel_sigma", pixel_sigma)
    s = np.broadcast_to(s, (4,)) if s.ndim == 0 else s
    if s.shape != (4,):
        raise PerceptionError(f"pixel_sigma must be a scalar or shape (4,), got shape {s.shape}")
    if np.any(s > 1e100):
        raise PerceptionError(f"pixel_sigma must be at most 1e100 pixels, got {s.tolist()}")
    from ..errors import BehindCameraError
    from .stereo import _check_triangulated

    u1, u2 = _matched_pixels(rig, uv_left, uv_right)
    n = u1.shape[0]
    # The cheap check first (one triangulation per pair, chunk by chunk): a pair at infinity or
    # behind the camera is reported before the 8 perturbed triangulations of every pair.
    for a in range(0, n, COVARIANCE_CHUNK):
        b = min(n, a + COVARIANCE_CHUNK)
        xy1, xy2 = rig.normalized(u1[a:b], u2[a:b])
        _check_triangulated(rig._triangulate_normalized(xy1, xy2), u1[a:b], u2[a:b], offset=a)
    C = np.empty((n, 3, 3))
    for a in range(0, n, COVARIANCE_CHUNK):  # chunks keep the 8 perturbed copies' memory bounded
        b = min(n, a + COVARIANCE_CHUNK)
        try:
            J = triangulation_jacobian(rig, u1[a:b], u2[a:b])
        except BehindCameraError as exc:
            raise BehindCameraError(
                f"pixel pairs {a}..{b - 1}: a pair moved by the differentiation step (1e-3 px) triangulates "
                f"at infinity or behind the camera (disparity too small): {exc}"
            ) from exc
        with np.errstate(over="ignore", invalid="ignore"):
            C[a:b] = np.einsum("nik,k,njk->nij", J, s**2, J)
        bad = ~np.all(np.isfinite(C[a:b]), axis=(1, 2))
        if np.any(bad):
            i = a + int(np.flatnonzero(bad)[0])
            raise PerceptionError(f"the covariance of pixel pair {i} overflows (pixel_sigma {s.tolist()})")
    return C


#: Pixel pairs processed at once by :func:`triangulation_covariance` (bounds its working memory).
COVARIANCE_CHUNK = 65_536


def class_bandwidth(vertices: ArrayLike) -> NDArray[np.float64]:
    """Fusion bandwidth of a class: the covariance of its model's vertices (section 2.2).

    Parameters
    ----------
    vertices : (k, 3) float
        Vertices of the class's geometric model, k >= 2.

    Returns
    -------
    (3, 3) float
        ``(V - mean)^T (V - mean) / k``.
    """
    V = real_array("vertices", vertices, (None, 3))
    if V.shape[0] < 2:
        raise PerceptionError(f"vertices must have shape (k, 3) with k >= 2, got shape {V.shape}")
    big = np.flatnonzero(np.any(np.abs(V) > 1e150, axis=1))
    if big.size:
        raise PerceptionError(f"vertices[{big[0]}] = {V[big[0]].tolist()} exceeds 1e150 in magnitude")
    D = V - V.mean(axis=0)
    return D.T @ D / V.shape[0]
