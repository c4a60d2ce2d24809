"""Rigid pose from matched points: the eq.-5 frames and weighted Kabsch (paper section 2.3).

Frames follow docs/conventions.md: a 4x4 matrix ``a_from_b`` maps coordinates in frame ``b``
to frame ``a``.  :func:`pose_from_frames` returns ``world_from_ego``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from .._checks import integer, real_array, real_scalar
from .._rigid import rigid_transform
from ..errors import PoseError, WorldGraphError
from ..tolerances import COLLINEAR_TOL as COLLINEAR_TOL  # re-exported: worldgraph.pose.COLLINEAR_TOL
from ..tolerances import (
    COST_DECREASE_RTOL,
    GRADIENT_RTOL,
    ISOTROPIC_RTOL,
    LM_LAMBDA_MIN,
    LM_LAMBDA_START,
    LM_SHIFT,
    PD_RTOL,
    REFINE_TOL,
    SAME_ROTATION,
    SIGNIFICANCE,
    SMALL_ANGLE,
    START_IMPROVEMENT,
    STEP_RTOL,
    STEP_TOL,
    SYMMETRY_RTOL,
    TINY,
)
from .gravity import TiltPrior, _check_tilt_prior

__all__ = [
    "invert_transformation",
    "percept_frame",
    "pose_from_frames",
    "pose_information",
    "refine_pose",
    "rotation_angle",
    "transformation",
    "weighted_kabsch",
    "weighted_kabsch_batch",
    "weighted_rotation",
]

#: Iteration cap of :func:`refine_pose`'s final polish (its ``max_iter`` default).
REFINE_MAX_ITER = 200
#: Largest coordinate (m) the pose functions accept: squares and weighted sums stay finite.
MAX_POSE_COORDINATE = 1e12


def _points(name: str, x: ArrayLike, n: int | None = None, like: str = "") -> NDArray[np.float64]:
    """(n, 3) points; ``like`` names the argument whose length ``n`` is (for the mismatch message)."""
    out = real_array(name, x, (None, 3), max_abs=MAX_POSE_COORDINATE)
    if n is not None and len(out) != n:
        raise WorldGraphError(f"{name} must have shape ({n}, 3){f' like {like}' if like else ''}, "
                              f"got shape {out.shape}")
    return out


def _point(name: str, x: ArrayLike) -> NDArray[np.float64]:
    return real_array(name, x, (3,), max_abs=MAX_POSE_COORDINATE)


def transformation(rotation: ArrayLike, translation: ArrayLike) -> NDArray[np.float64]:
    """4x4 homogeneous matrix from ``rotation (3, 3)`` and ``translation (3,)``."""
    rot = real_array("rotation", rotation, (3, 3))
    out = np.eye(4)
    out[:3, :3] = rot
    out[:3, 3] = _point("translation", translation)
    return out


def invert_transformation(a_from_b: ArrayLike) -> NDArray[np.float64]:
    """Inverse ``b_from_a`` of a rigid 4x4 transform (rotation transposed)."""
    m = rigid_transform("a_from_b", a_from_b)
    out = np.eye(4)
    out[:3, :3] = m[:3, :3].T
    out[:3, 3] = -m[:3, :3].T @ m[:3, 3]
    return out


def _rotation_block(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """The rotation of a (3, 3) rotation or a (4, 4) rigid transform."""
    arr = real_array(name, value)
    if arr.shape == (4, 4):
        return rigid_transform(name, arr)[:3, :3]
    if arr.shape != (3, 3):
        raise WorldGraphError(f"{name} must have shape (3, 3) or (4, 4), got shape {arr.shape}")
    padded = np.eye(4)
    padded[:3, :3] = arr
    return rigid_transform(name, padded)[:3, :3]


def rotation_angle(rotation_a: ArrayLike, rotation_b: ArrayLike) -> float:
    """Angle (rad) of the relative rotation ``R_a^T R_b``."""
    ra = _rotation_block("rotation_a", rotation_a)
    rb = _rotation_block("rotation_b", rotation_b)
    c = (np.trace(ra.T @ rb) - 1.0) / 2.0
    return float(np.arccos(np.clip(c, -1.0, 1.0)))


def percept_frame(a: ArrayLike, b: ArrayLike, c: ArrayLike) -> NDArray[np.float64]:
    """The frame ``S^{i,j,k}`` of three non-collinear points (paper section 2.2, used in eq. 5).

    Origin ``a``; ``d1 = (b - a) / |b - a|``; ``d2 = d1 x (c - a)`` normalised; ``d3 = d1 x d2``.
    The columns ``d1, d2, d3`` form a proper rotation (det +1).

    Parameters
    ----------
    a, b, c : (3,) float

    Returns
    -------
    (4, 4) float
        ``parent_from_frame``: maps frame coordinates to the coordinates ``a, b, c`` are in.

    Raises
    ------
    WorldGraphError
        A wrongly shaped, non-finite or too large (> 1e12 m) point.
    PoseError
        Collinear (or coincident) points.
    """
    pa, pb, pc = _point("a", a), _point("b", b), _point("c", c)
    ab = pb - pa
    ac = pc - pa
    scale = max(float(np.dot(ab, ab)), float(np.dot(ac, ac)))
    nab = float(np.linalg.norm(ab))
    cross = np.cross(ab / nab if nab > 0 else ab, ac)
    ncross = float(np.linalg.norm(cross))
    if nab == 0.0 or scale == 0.0 or ncross * nab <= COLLINEAR_TOL * scale:
        raise PoseError(f"points a={pa.tolist()}, b={pb.tolist()}, c={pc.tolist()} are collinear "
                        "(or coincident): they define no frame")
    d1 = ab / nab
    d2 = cross / ncross
    d3 = np.cross(d1, d2)
    return transformation(np.column_stack([d1, d2, d3]), pa)


def pose_from_frames(model_frame: ArrayLike, percept_frame_: ArrayLike) -> NDArray[np.float64]:
    """Eq. 5: ``world_from_ego = S_model @ S_percept^-1``.

    Parameters
    ----------
    model_frame : (4, 4) float
        :func:`percept_frame` of the model points (world coordinates), ``world_from_triple``.
    percept_frame_ : (4, 4) float
        :func:`percept_frame` of the matching percepts (ego coordinates), ``ego_from_triple``.

    Returns
    -------
    (4, 4) float
        ``world_from_ego``.
    """
    m = rigid_transform("model_frame", model_frame, max_translation=MAX_POSE_COORDINATE)
    s = rigid_transform("percept_frame_", percept_frame_, max_translation=MAX_POSE_COORDINATE)
    return m @ invert_transformation(s)


def _weights(weights: ArrayLike, k: int) -> NDArray[np.float64]:
    w = real_array("weights", weights, (k,))
    neg = w < 0
    if neg.any():
        i = int(np.argmax(neg))
        raise PoseError(f"weights[{i}] must be >= 0, got {w[i]!r}")
    if not np.any(w > 0):
        raise PoseError(f"weights must not all be 0, got {w.tolist()!r:.200}")
    top = float(w.max())
    if top > 1e150 or top < 1e-150:
        raise PoseError(f"weights must lie within [1e-150, 1e150] (largest {top:.3g}): rescale them")
    return w


def _proper_rotation(cross_cov: NDArray[np.float64]) -> NDArray[np.float64]:
    """R maximising trace(R^T H) over SO(3) for ``H = sum w y x^T`` (maps x onto y)."""
    u, _, vt = np.linalg.svd(cross_cov)
    d = np.sign(np.linalg.det(u @ vt))
    if d == 0:
        d = 1.0
    return u @ np.diag([1.0, 1.0, d]) @ vt


def weighted_rotation(ego_vectors: ArrayLike, world_vectors: ArrayLike, weights: ArrayLike
                      ) -> NDArray[np.float64]:
    """Proper rotation R minimising ``sum_i w_i |R x_i - y_i|^2`` (no translation, no scale).

    Parameters
    ----------
    ego_vectors : (k, 3) float
    world_vectors : (k, 3) float
    weights : (k,) float, >= 0

    Returns
    -------
    (3, 3) float
        A rotation (det +1); the reflection an unconstrained fit would give is avoided by
        flipping the least significant singular direction (Umeyama 1991).
    """
    x = _points("ego_vectors", ego_vectors)
    y = _points("world_vectors", world_vectors, len(x), "ego_vectors")
    w = _weights(weights, len(x))
    return _proper_rotation((y * w[:, None]).T @ x)


def weighted_kabsch(ego_points: ArrayLike, world_points: ArrayLike, weights: ArrayLike
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Weighted Kabsch/Umeyama without scaling: ``min sum_i w_i |R x_i + t - X_i|^2``.

    Parameters
    ----------
    ego_points : (k, 3) float
        Points in the ego frame.
    world_points : (k, 3) float
        The matching points in the world frame.
    weights : (k,) float, >= 0
        E.g. ``1 / sigma_i^2``.

    Returns
    -------
    R : (3, 3) float
        Proper rotation (det +1), world_from_ego rotation.
    t : (3,) float
        Translation, so that ``X ~ R x + t``.
    """
    x = _points("ego_points", ego_points)
    y = _points("world_points", world_points, len(x), "ego_points")
    return _weighted_kabsch(x, y, _weights(weights, len(x)))


def _weighted_kabsch(x: NDArray, y: NDArray, w: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`weighted_kabsch` of checked arrays (the ML fit's start, once per refinement)."""
    wn = w / w.sum()
    cx = wn @ x
    cy = wn @ y
    rot = _proper_rotation(((y - cy) * wn[:, None]).T @ (x - cx))
    return rot, cy - rot @ cx


def weighted_kabsch_batch(ego_points: ArrayLike, world_points: ArrayLike, weights: ArrayLike
                          ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`weighted_kabsch` of ``h`` point sets of one size at once.

    Parameters
    ----------
    ego_points, world_points : (h, k, 3) float
    weights : (h, k) float, > 0

    Returns
    -------
    R : (h, 3, 3) float
        Proper rotations.
    t : (h, 3) float
    """
    x = real_array("ego_points", ego_points, (None, None, 3), max_abs=MAX_POSE_COORDINATE)
    y = real_array("world_points", world_points, x.shape, max_abs=MAX_POSE_COORDINATE)
    w = real_array("weights", weights, x.shape[:2])
    neg = np.argwhere(w < 0)
    if len(neg):
        i, j = neg[0]
        raise PoseError(f"weights[{i}, {j}] must be >= 0, got {w[i, j]!r}")
    if len(w) and (w.shape[1] == 0 or np.any(w.sum(axis=1) <= 0) or float(w.max()) > 1e150):
        raise PoseError("weights must not all be 0 in any set and must be <= 1e150")
    wn = w / w.sum(axis=1, keepdims=True)
    cx = np.einsum("hk,hki->hi", wn, x)
    cy = np.einsum("hk,hki->hi", wn, y)
    cross_cov = np.einsum("hk,hki,hkj->hij", wn, y - cy[:, None], x - cx[:, None])
    u, _, vt = np.linalg.svd(cross_cov)
    d = np.sign(np.linalg.det(u @ vt))
    d[d == 0] = 1.0
    u[:, :, 2] *= d[:, None]
    rot = u @ vt
    return rot, cy - np.einsum("hij,hj->hi", rot, cx)


def _skew(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(k, 3) -> (k, 3, 3)`` cross-product matrices, ``skew(a) @ b = a x b``."""
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def _covariances(covariances: ArrayLike, k: int, name: str = "covariances", like: str = ""
                 ) -> NDArray[np.float64]:
    """(k, 3, 3) symmetric positive-definite covariances (m^2), named by index when one is not.

    ``name`` is the caller's argument name, used in the messages."""
    C = real_array(name, covariances, (None, 3, 3))
    if len(C) != k:
        raise WorldGraphError(f"{name} must have shape ({k}, 3, 3){f' like {like}' if like else ''}, "
                              f"got shape {C.shape}")
    asym = (np.abs(C - np.swapaxes(C, 1, 2)).max(axis=(1, 2))
            > SYMMETRY_RTOL * np.abs(C).max(axis=(1, 2)) + TINY)
    if asym.any():
        i = int(np.argmax(asym))
        raise PoseError(f"{name}[{i}] must be symmetric, got {C[i].tolist()}")
    ev = np.linalg.eigvalsh(C) if k else np.zeros((0, 3))
    bad = (ev[:, 0] <= 0) if k else np.zeros(0, bool)
    if bad.any():
        i = int(np.argmax(bad))
        raise PoseError(f"{name}[{i}] must be symmetric positive definite (smallest eigenvalue "
                        f"{ev[i, 0]:.3g})")
    out = (ev[:, 0] < 1e-100) | (ev[:, -1] > 1e100) if k else np.zeros(0, bool)
    if out.any():
        i = int(np.argmax(out))
        raise PoseError(f"{name}[{i}] has eigenvalues {ev[i, 0]:.3g}..{ev[i, -1]:.3g} m^2, outside "
                        "[1e-100, 1e100]: its inverse (the weight) under- or overflows")
    return C


def pose_information(world_from_ego: ArrayLike, ego_points: ArrayLike, covariances: ArrayLike
                     ) -> NDArray[np.float64]:
    """Fisher information ``(6, 6)`` of the pose from 3D point correspondences.

    Model: ``X_i = R x_i + t`` exactly for the world points, ``x_i`` measured in the ego
    frame with covariance ``C_i``.  Parameters ``(dtheta, dt)``: a rotation vector applied on
    the left, ``R <- exp(dtheta) R``, and the translation (the robot position).  With the
    world residual ``e_i = R x_i + t - X_i`` (covariance ``R C_i R^T``) and its Jacobian
    ``H_i = [-skew(R x_i), I]``, ``J = sum_i H_i^T (R C_i R^T)^-1 H_i``.
    """
    T = rigid_transform("world_from_ego", world_from_ego, max_translation=MAX_POSE_COORDINATE)
    x = _points("ego_points", ego_points)
    C = _covariances(covariances, len(x), like="ego_points")
    return _pose_information(T, x, C)


def _pose_information(T: NDArray, x: NDArray, C: NDArray) -> NDArray[np.float64]:
    """:func:`pose_information` of checked arrays (the fits call it once per refinement)."""
    R = T[:3, :3]
    W = np.linalg.inv(R @ C @ R.T)  # (k, 3, 3)
    # an ill-conditioned covariance (a needle: variances 1e-8 and 1e4 m^2) has an inverse that is
    # symmetric only to ~1e-16 times its condition number; J is symmetric by definition
    W = 0.5 * (W + np.swapaxes(W, 1, 2))
    H = np.concatenate([-_skew(x @ R.T), np.broadcast_to(np.eye(3), (len(x), 3, 3))], axis=2)
    J = np.einsum("kai,kab,kbj->ij", H, W, H)
    return 0.5 * (J + J.T)


#: Rotations screened by :func:`refine_pose` for its starts (fixed seed: deterministic).
_GRID_SIZE = 2048
_GRID: NDArray[np.float64] | None = None


def _rotation_grid() -> NDArray[np.float64]:
    """``(N, 10)`` liftings ``[vec(R^T) (column-major); 1]`` of a fixed set of rotations."""
    global _GRID
    if _GRID is None:
        rots = Rotation.random(_GRID_SIZE, random_state=np.random.default_rng(20261130)).as_matrix()
        lift = np.ones((_GRID_SIZE, 10))
        lift[:, :9] = rots.reshape(_GRID_SIZE, 9)  # vec(R^T) column-major = the rows of R
        _GRID = np.concatenate([lift, rots.reshape(_GRID_SIZE, 9)], axis=1)
    return _GRID


def _reduced_matrix(x: NDArray, y: NDArray, Cinv: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """``Q`` (10, 10) with ``min_t cost(R, t) = l^T Q l``, ``l = [vec(R^T); 1]`` (centred points),
    and ``(W^-1 G, cx, cy)`` giving the optimal translation of a rotation (see
    :mod:`worldgraph.pose.certificate` for the derivation)."""
    cx, cy = x.mean(axis=0), y.mean(axis=0)
    xc, yc = x - cx, y - cy
    B = np.zeros((len(x), 3, 10))
    for j in range(3):
        B[:, :, 3 * j:3 * j + 3] = -yc[:, j, None, None] * np.eye(3)
    B[:, :, 9] = xc
    H = np.einsum("kai,kab,kbj->ij", B, Cinv, B)
    G = np.einsum("kab,kbj->aj", Cinv, B)
    WinvG = np.linalg.solve(Cinv.sum(axis=0), G)
    Q = H - G.T @ WinvG
    return 0.5 * (Q + Q.T), WinvG, cx, cy


def _lift(R: NDArray) -> NDArray:
    """``[vec(R^T) (column-major); 1]``."""
    return np.concatenate([R.T.reshape(-1, order="F"), [1.0]])


def _best_translation(R: NDArray, WinvG: NDArray, cx: NDArray, cy: NDArray) -> NDArray:
    """The translation minimising the cost for the rotation ``R``."""
    u = -WinvG @ _lift(R)
    return cy + R @ (u - cx)


_UNIT_SKEW = np.array([[[0.0, 0, 0], [0, 0, -1], [0, 1, 0]],
                       [[0.0, 0, 1], [0, 0, 0], [-1, 0, 0]],
                       [[0.0, -1, 0], [1, 0, 0], [0, 0, 0]]])  # skew(e_j)


def _expm(w: NDArray) -> NDArray:
    """Rotation matrix of the rotation vector ``w`` (Rodrigues; no scipy overhead)."""
    theta = math.sqrt(float(w @ w))
    if theta < SMALL_ANGLE:
        return np.eye(3) + _skew(w)
    K = _skew(w / theta)
    return np.eye(3) + math.sin(theta) * K + (1.0 - math.cos(theta)) * (K @ K)


def _logm(R: NDArray) -> NDArray[np.float64]:
    """Rotation vector of the rotation matrix ``R`` (the inverse of ``_expm``; angle in
    [0, pi]), through the unit quaternion of the largest of ``1 + trace`` and ``1 + 2 R_ii -
    trace`` (no cancellation near pi) and ``angle / sin(angle / 2)`` (its series near 0).  No
    scipy overhead: the validation compares poses thousands of times a second."""
    tr = float(R[0, 0] + R[1, 1] + R[2, 2])
    k = int(np.argmax([R[0, 0], R[1, 1], R[2, 2]]))
    if tr >= R[k, k]:
        w = 0.5 * math.sqrt(max(1.0 + tr, 0.0))
        v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / (4.0 * w)
    else:
        i, j = (k + 1) % 3, (k + 2) % 3
        v = np.empty(3)
        v[k] = 0.5 * math.sqrt(max(1.0 + 2.0 * R[k, k] - tr, 0.0))
        v[i] = (R[i, k] + R[k, i]) / (4.0 * v[k])
        v[j] = (R[j, k] + R[k, j]) / (4.0 * v[k])
        w = (R[j, i] - R[i, j]) / (4.0 * v[k])
        if w < 0.0:
            w, v = -w, -v
    s = math.sqrt(float(v @ v))
    angle = 2.0 * math.atan2(s, w)
    if angle < SMALL_ANGLE:  # angle / sin(angle / 2) = 2 + angle^2 / 12 + ...
        return (2.0 + angle * angle / 12.0) * v / math.hypot(s, w)
    return (angle / s) * v


def _reduced_descent(Q: NDArray, R: NDArray, max_iter: int) -> NDArray:
    """Local minimum over SO(3) of ``l(R)^T Q l(R)`` by damped Newton (exact Hessian).

    With ``R <- exp(w) R``, ``M = R^T`` moves to ``M (I - skew(w) + skew(w)^2 / 2)``, so the
    cost is ``f + 2 b^T w + w^T (D^T Q D + sym(P) - tr(P) I) w`` to second order, with
    ``D[3j:3j+3] = M skew(e_j)``, ``b = D^T Q l``, ``P = G^T M`` and ``G`` the 3x3 of ``(Q l)[:9]``.
    """
    f = float(_lift(R) @ Q @ _lift(R))
    for _ in range(max_iter):
        M = R.T
        lr = _lift(R)
        D = np.zeros((10, 3))
        D[:9] = np.einsum("ab,jbc->jac", M, _UNIT_SKEW).reshape(9, 3)
        Ql = Q @ lr
        b = D.T @ Ql
        P = Ql[:9].reshape(3, 3, order="F").T @ M
        H = D.T @ Q @ D + 0.5 * (P + P.T) - np.trace(P) * np.eye(3)
        lo = float(np.linalg.eigvalsh(H)[0])
        scale = max(float(np.abs(H).max()), TINY)
        mu = 0.0 if lo > PD_RTOL * scale else -lo + LM_SHIFT * scale
        improved = False
        for _damp in range(40):
            step = -np.linalg.solve(H + mu * np.eye(3), b)
            norm = float(np.linalg.norm(step))
            if norm > 1.0:  # a trust region of 1 rad
                step = step / norm
            Rn = _expm(step) @ R
            fn = float(_lift(Rn) @ Q @ _lift(Rn))
            if fn <= f:
                improved = True
                break
            mu = max(10.0 * mu, LM_SHIFT * scale)
        if not improved:
            break
        done = f - fn <= COST_DECREASE_RTOL * max(f, TINY) or float(np.linalg.norm(step)) < STEP_TOL
        R, f = Rn, fn
        if done:
            break
    return R


def refine_pose(ego_points: ArrayLike, world_points: ArrayLike, covariances: ArrayLike,
                world_from_ego: ArrayLike, max_iter: int = REFINE_MAX_ITER, tol: float = REFINE_TOL, *,
                tilt_prior: TiltPrior | None = None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Maximum-likelihood pose from 3D correspondences with per-point covariances.

    Minimises ``sum_i r_i^T C_i^-1 r_i`` with the ego-frame residual ``r_i = x_i - R^T (X_i - t)``
    (the negative log-likelihood of the measured ``x_i``; metres, covariances in m^2).

    The cost is not convex in the rotation: with elongated (needle-shaped) covariances a local
    method started from a Kabsch pose can end far from the optimum.  So the translation is
    eliminated in closed form (``min_t cost = l^T Q l`` with a 10x10 ``Q``,
    :mod:`worldgraph.pose.certificate`), a fixed grid of 2048 rotations is screened on that
    reduced cost, and damped Gauss-Newton on SO(3) runs from ``world_from_ego``, from the
    weighted Kabsch pose (weights ``3 / trace C_i``) and from the best grid rotations (those
    below the best minimum so far, or, when that minimum's cost is implausible, above the
    ``1 - SIGNIFICANCE`` quantile of chi-square with ``3 k`` degrees of freedom, the lowest
    ones: needles of 1e-8 m^2 make the cost so sharp that every grid rotation costs more than a
    far local minimum); the best
    is polished by Levenberg-Marquardt on the full residuals until the relative cost decrease
    falls below ``tol`` and the step below 1e-10.  For isotropic ``C_i = s_i^2 I`` the optimum
    is :func:`weighted_kabsch` with weights ``1 / s_i^2`` (closed form).

    With ``tilt_prior`` (:class:`~worldgraph.pose.gravity.TiltPrior`: gravity's word on roll and
    pitch) the cost gains the prior's ``|(R up)_xy|^2 / sd^2``: the data's optimum is polished by
    Levenberg-Marquardt on both, and the information gains the prior's (its roll and pitch).

    Parameters
    ----------
    ego_points, world_points : (k, 3) float
        Metres; at least 3 pairs (fewer raise PoseError).
    covariances : (k, 3, 3) float
        Covariance (m^2) of each ego point, symmetric positive definite.
    world_from_ego : (4, 4) float
        A rigid start (its rotation is one of the starts).
    max_iter : int
        Iteration cap of the final Levenberg-Marquardt polish (>= 1).
    tol : float
        Relative cost decrease that counts as converged (> 0, < 1).
    tilt_prior : TiltPrior, optional
        Gravity as a prior on the tilt (None: the 6D fit of the data alone).

    Returns
    -------
    world_from_ego : (4, 4) float
    information : (6, 6) float
        :func:`pose_information` at the result; its inverse's lower-right block is the
        Cramer-Rao bound of the position.

    Raises
    ------
    PoseError
        Degenerate correspondences (singular information), or no convergence within
        ``max_iter`` iterations (never reported as converged at the cap).
    """
    x = _points("ego_points", ego_points)
    y = _points("world_points", world_points, len(x), "ego_points")
    if len(x) < 3:
        raise PoseError(f"ego_points must hold at least 3 correspondences for a pose, got {len(x)}")
    C = _covariances(covariances, len(x), like="ego_points")
    T0 = rigid_transform("world_from_ego", world_from_ego, max_translation=MAX_POSE_COORDINATE)
    max_iter = integer("max_iter", max_iter, minimum=1)
    tol = real_scalar("tol", tol, positive=True, maximum=0.5)
    tilt_prior = _check_tilt_prior(tilt_prior)
    return _refine_pose(x, y, C, T0, max_iter, tol, tilt_prior)


def _refine_pose(x: NDArray, y: NDArray, C: NDArray, T0: NDArray, max_iter: int = REFINE_MAX_ITER,
                 tol: float = REFINE_TOL, tilt_prior: TiltPrior | None = None
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`refine_pose` of checked arrays (at least 3 pairs; covariances symmetric positive
    definite; a rigid start): the scale test, the fit, numerical failures as PoseError."""
    _finite_scale(x, y, C)
    try:
        pose, information, _ = ml_refine(x, y, C, T0, max_iter, tol, tilt_prior)
        return pose, information
    except (np.linalg.LinAlgError, FloatingPointError, ValueError) as exc:
        if isinstance(exc, PoseError):
            raise
        raise PoseError(f"refine_pose failed numerically ({exc}); covariance scales "
                        f"{np.trace(C, axis1=1, axis2=2).tolist()} m^2") from exc


def _finite_scale(x: NDArray, y: NDArray, C: NDArray) -> None:
    """Reject inputs whose whitened cost overflows or whose covariances underflow."""
    Cinv = np.linalg.inv(C)
    with np.errstate(all="ignore"):
        big = np.max(np.abs(Cinv), axis=(1, 2)) * (np.max(np.abs(x)) + np.max(np.abs(y)) + 1.0) ** 2
    bad = ~np.isfinite(big) | ~np.all(np.isfinite(Cinv), axis=(1, 2)) | (big > 1e250)
    if bad.any():
        i = int(np.argmax(bad))
        raise PoseError(f"covariances[{i}] (trace {float(np.trace(C[i])):.3g} m^2) is too small for "
                        "points of this size: the whitened cost overflows")


def _data_cost(x: NDArray, y: NDArray, Cinv: NDArray, R: NDArray, t: NDArray) -> float:
    r = x - (y - t) @ R  # ego-frame residual x_i - R^T (X_i - t), covariance C_i
    return float(np.einsum("ka,kab,kb->", r, Cinv, r))


def ml_refine(x: NDArray, y: NDArray, C: NDArray, T0: NDArray, max_iter: int, tol: float,
              tilt_prior: TiltPrior | None = None, search: bool = True
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """``(world_from_ego, information, tilt_chi2)``: the ML pose of the data (then, with
    ``tilt_prior``, of the data and the prior, polished from there), its information (with the
    prior's) and the cost the prior adds to the data's optimum (0 without a prior; the squared
    Mahalanobis distance between the data's tilt and the prior's, 2 degrees of freedom).
    ``search=False``: ``T0`` is the data's ML pose already (a validated fit), so the global
    search for it (grid starts) is skipped and it is only polished."""
    Cinv = np.linalg.inv(C)
    Cinv = 0.5 * (Cinv + np.swapaxes(Cinv, 1, 2))
    if search:
        R, t = _data_optimum(x, y, C, Cinv, T0, max_iter, tol)
    else:
        R, t = _polish(x, y, Cinv, T0[:3, :3], T0[:3, 3], max_iter, tol)
    if tilt_prior is None:
        out = transformation(R, t)
        return out, _pose_information(out, x, C), 0.0
    data_cost = _data_cost(x, y, Cinv, R, t)
    R, t = _polish(x, y, Cinv, R, t, max_iter, tol, tilt_prior)
    out = transformation(R, t)
    added = _data_cost(x, y, Cinv, R, t) + tilt_prior.cost(R) - data_cost
    return out, _pose_information(out, x, C) + tilt_prior.information(R), max(added, 0.0)


def _data_optimum(x: NDArray, y: NDArray, C: NDArray, Cinv: NDArray, T0: NDArray, max_iter: int, tol: float
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The ML rotation and translation of the data alone (global: grid starts, then polished)."""

    def cost(R: NDArray, t: NDArray) -> float:
        return _data_cost(x, y, Cinv, R, t)

    scale = np.trace(C, axis1=1, axis2=2) / 3.0
    Rk, tk = _weighted_kabsch(x, y, 1.0 / scale)
    if np.allclose(C, scale[:, None, None] * np.eye(3), rtol=ISOTROPIC_RTOL, atol=0.0):
        return (Rk, tk) if cost(Rk, tk) <= cost(T0[:3, :3], T0[:3, 3]) else (T0[:3, :3], T0[:3, 3])
    Q, WinvG, cx, cy = _reduced_matrix(x, y, Cinv)
    best_R, best_f = T0[:3, :3], np.inf
    starts = [T0[:3, :3]] if np.abs(T0[:3, :3] - Rk).max() < SAME_ROTATION else [T0[:3, :3], Rk]
    for R in starts:  # the local minima of the given and the Kabsch start ...
        R = _reduced_descent(Q, R, 50)
        f = float(_lift(R) @ Q @ _lift(R))
        if f < best_f:
            best_R, best_f = R, f
    # ... then every basin that a grid rotation shows to hold a lower reduced cost
    grid = _rotation_grid()
    vals = np.sum((grid[:, :10] @ Q) * grid[:, :10], axis=1)
    lower = np.flatnonzero(vals < best_f - START_IMPROVEMENT * max(best_f, 1.0))
    if best_f > float(chi2.ppf(1.0 - SIGNIFICANCE, 3 * len(x))):
        # an implausible fit (cost far above chi-square with 3k degrees of freedom): a sharp cost
        # (needles of 1e-8 m^2) can put every grid rotation above it, yet a better basin lies
        # between them; descend from the lowest grid rotations regardless
        lower = np.arange(len(vals))
    tried: list[NDArray] = []
    for i in lower[np.argsort(vals[lower])][:64]:
        Rg = grid[i, 10:].reshape(3, 3)
        if any(rotation_angle(Rg, s) < 0.5 for s in tried):
            continue
        tried.append(Rg)
        R = _reduced_descent(Q, Rg, 50)
        f = float(_lift(R) @ Q @ _lift(R))
        if f < best_f:
            best_R, best_f = R, f
        if len(tried) >= 4:
            break
    R = best_R
    t = _best_translation(R, WinvG, cx, cy)
    current = cost(R, t)
    start_cost = cost(T0[:3, :3], T0[:3, 3])
    if start_cost < current:
        R, t, current = T0[:3, :3], T0[:3, 3], start_cost
    return _polish(x, y, Cinv, R, t, max_iter, tol)


def _polish(x: NDArray, y: NDArray, Cinv: NDArray, R: NDArray, t: NDArray, max_iter: int, tol: float,
            tilt_prior: TiltPrior | None = None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Levenberg-Marquardt on the full residuals (and the tilt prior's) from ``(R, t)``."""

    def cost(R: NDArray, t: NDArray) -> float:
        return _data_cost(x, y, Cinv, R, t) + (tilt_prior.cost(R) if tilt_prior is not None else 0.0)

    current = cost(R, t)
    lam = LM_LAMBDA_START
    converged = False
    for _ in range(max_iter):
        # R <- exp(dtheta) R, t <- t + dt:  dr = -R^T skew(X - t) dtheta + R^T dt
        H = np.concatenate([-np.einsum("ba,kbc->kac", R, _skew(y - t)),
                            np.broadcast_to(R.T, (len(x), 3, 3))], axis=2)
        r = x - (y - t) @ R
        J = np.einsum("kai,kab,kbj->ij", H, Cinv, H)
        g = np.einsum("kai,kab,kb->i", H, Cinv, r)
        if tilt_prior is not None:
            Jp = tilt_prior.jacobian(R)
            J[:3, :3] += Jp.T @ Jp
            g[:3] += Jp.T @ tilt_prior.residual(R)
        dscale = np.sqrt(np.maximum(np.diag(J), TINY))
        if (float(np.linalg.norm(g / dscale)) <= GRADIENT_RTOL * math.sqrt(max(current, TINY))
                or current == 0.0):
            converged = True
            break
        accepted = False
        for _damp in range(40):
            try:
                step = -np.linalg.solve(J + lam * np.diag(np.diag(J)), g)
            except np.linalg.LinAlgError as exc:
                raise PoseError("the correspondences do not fix a pose (singular information)") from exc
            Rn = _expm(step[:3]) @ R
            u, _, vt = np.linalg.svd(Rn)  # stay on SO(3)
            Rn = u @ vt
            tn = t + step[3:]
            new = cost(Rn, tn)
            if new <= current:
                accepted = True
                break
            lam = lam * 10.0
        if not accepted:  # no descent direction left at machine precision: a minimum
            converged = True
            break
        small = float(np.linalg.norm(step * dscale)) <= STEP_RTOL * math.sqrt(max(current, 1.0))
        R, t = Rn, tn
        done = current - new <= tol * max(1.0, current) or small
        current = new
        lam = max(lam / 10.0, LM_LAMBDA_MIN)
        if done:
            converged = True
            break
    if not converged:
        raise PoseError(f"refine_pose did not converge in max_iter={max_iter} iterations "
                        f"(cost {current:.6g})")
    return R, t
