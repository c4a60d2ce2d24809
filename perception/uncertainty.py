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

from .errors import NonFiniteError, NonPositiveSigmaError, ShapeError

if TYPE_CHECKING:
    from .stereo import StereoRig


def _finite(name: str, value: ArrayLike) -> NDArray[np.float64]:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ShapeError(f"{name} must be real numbers, got {value!r}") from exc
    if not np.all(np.isfinite(arr)):
        raise NonFiniteError(f"{name} must be finite, got {arr.tolist()} (shape {arr.shape})")
    return arr


def _positive(name: str, value: ArrayLike) -> NDArray[np.float64]:
    arr = _finite(name, value)
    if np.any(arr <= 0):
        raise NonPositiveSigmaError(f"{name} must be > 0, got {arr.tolist()}")
    return arr


def _out(x: NDArray[np.float64]) -> NDArray[np.float64] | float:
    return float(x) if x.ndim == 0 else x


def perception_depth(
    points: ArrayLike, camera_center: ArrayLike, viewing_direction: ArrayLike
) -> NDArray[np.float64] | float:
    """Perception depth ``rho = (x - C_L) . e_d`` (eq. 7).

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
    C = _finite("camera_center", camera_center)
    e = _finite("viewing_direction", viewing_direction)
    if X.shape[-1:] != (3,) or X.ndim > 2:
        raise ShapeError(f"points must have shape (3,) or (N, 3), got shape {X.shape}")
    if C.shape != (3,):
        raise ShapeError(f"camera_center must have shape (3,), got shape {C.shape}")
    if e.shape != (3,):
        raise ShapeError(f"viewing_direction must have shape (3,), got shape {e.shape}")
    n = np.linalg.norm(e)
    if n == 0:
        raise NonPositiveSigmaError(f"viewing_direction must be non-zero, got {e.tolist()}")
    return _out((X - C) @ (e / n))


def depth_sigma(rho: ArrayLike, depth_factor: float) -> NDArray[np.float64] | float:
    """Standard deviation of a percept at perception depth ``rho``: ``rho^2 / depth_factor`` (eq. 6).

    Parameters
    ----------
    rho : float or (N,) float
        Perception depth, metres (finite).
    depth_factor : float
        The paper's empirical factor (its ζ), > 0, in 1/metres.
    """
    r = _finite("rho", rho)
    df = _positive("depth_factor", depth_factor)
    if df.ndim != 0:
        raise ShapeError(f"depth_factor must be a scalar, got shape {df.shape}")
    return _out(r**2 / df)


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
    r = _positive("rho", rho)
    f = _positive("focal_px", focal_px)
    b = _positive("baseline", baseline)
    return _out(f * b / r)


def pixel_footprint(
    rho: ArrayLike, hfov: float, vfov: float, width: int, height: int
) -> NDArray[np.float64] | float:
    """Area imaged into one pixel at depth ``rho``: ``rho^2 tan(hfov / width) tan(vfov / height)``.

    The ``A_i`` formula of section 3.1; angles in radians, image size in pixels.
    """
    r = _finite("rho", rho)
    h = _positive("hfov", hfov)
    v = _positive("vfov", vfov)
    w = _positive("width", width)
    hh = _positive("height", height)
    return _out(r**2 * np.tan(h / w) * np.tan(v / hh))


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
    from .stereo import _points

    u1 = _points("uv_left", uv_left, 2)
    u2 = _points("uv_right", uv_right, 2)
    if u1.shape != u2.shape:
        raise ShapeError(f"uv_left and uv_right must have the same shape, got {u1.shape} and {u2.shape}")
    h = float(_positive("step", step))
    n = u1.shape[0]
    base = np.hstack([u1, u2])  # (N, 4)
    # 8 perturbed copies: +h and -h on each of the 4 coordinates
    delta = np.vstack([np.eye(4) * h, -np.eye(4) * h])  # (8, 4)
    pert = (base[None, :, :] + delta[:, None, :]).reshape(-1, 4)
    X = rig.triangulate(pert[:, :2], pert[:, 2:]).reshape(8, n, 3)
    J = (X[:4] - X[4:]) / (2.0 * h)  # (4, N, 3)
    return np.transpose(J, (1, 2, 0))


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
        raise ShapeError(f"pixel_sigma must be a scalar or shape (4,), got shape {s.shape}")
    J = triangulation_jacobian(rig, uv_left, uv_right)
    return np.einsum("nik,k,njk->nij", J, s**2, J)


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
    V = _finite("vertices", vertices)
    if V.ndim != 2 or V.shape[1] != 3 or V.shape[0] < 2:
        raise ShapeError(f"vertices must have shape (k, 3) with k >= 2, got shape {V.shape}")
    D = V - V.mean(axis=0)
    return D.T @ D / V.shape[0]
