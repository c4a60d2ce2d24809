"""Percept fusion by mean shift with the Epanechnikov kernel (paper section 2.2, Fig. 4).

Raw percepts of one type are clustered by mean shift; the percepts converging to one mode
form its delineation set, which is melted into one fused percept. Sets with fewer than
``min_views`` raw views (stragglers, typically false percepts) are rejected.

With the Epanechnikov kernel the mean-shift step is the (weighted) mean of the points inside
the kernel's support (its shadow is the flat kernel), so each iteration is exact and the
procedure stops at a fixed point after finitely many steps.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import NonFiniteError, NonPositiveSigmaError, PerceptionError, ShapeError, UnknownClassError
from .percept import Percept

DEFAULT_BANDWIDTH = 0.1
"""Default kernel radius, metres."""

MERGE_RADIUS = 0.5
"""Converged points closer than this (in bandwidth units) belong to one mode."""


def _bandwidth_matrix(name: str, value: float | ArrayLike) -> NDArray[np.float64]:
    """A (3, 3) SPD bandwidth matrix from a radius (metres) or a matrix."""
    try:
        H = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ShapeError(f"{name} must be a float or a (3, 3) matrix, got {value!r}") from exc
    if not np.all(np.isfinite(H)):
        raise NonFiniteError(f"{name} must be finite, got {H.tolist()}")
    if H.ndim == 0:
        if H <= 0:
            raise NonPositiveSigmaError(f"{name} must be > 0, got {float(H)!r}")
        return float(H) ** 2 * np.eye(3)
    if H.shape != (3, 3):
        raise ShapeError(f"{name} must be a scalar or shape (3, 3), got shape {H.shape}")
    if not np.allclose(H, H.T, rtol=1e-10, atol=1e-15) or np.linalg.eigvalsh(H).min() <= 0:
        raise NonPositiveSigmaError(f"{name} must be symmetric positive definite, got {H.tolist()}")
    return H


def mean_shift_modes(
    points: ArrayLike,
    bandwidth: float | ArrayLike,
    weights: ArrayLike | None = None,
    *,
    max_iter: int = 100,
    tol: float = 1e-6,
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Mean shift from every point with the Epanechnikov kernel of bandwidth matrix ``H``.

    A point ``y`` moves to the weighted mean of the points ``x`` with
    ``(x - y)^T H^-1 (x - y) < 1``; a float bandwidth ``h`` means ``H = h^2 I``. Points whose
    fixed points lie within ``MERGE_RADIUS`` (in ``H`` units) of a mode's first member (in
    input order) share that mode.

    Parameters
    ----------
    points : (n, d) float
    bandwidth : float or (d, d) float
        Kernel radius (length units) or SPD bandwidth matrix.
    weights : (n,) float, optional
        Positive point weights (default 1).
    max_iter : int
        Iteration limit per point.
    tol : float
        A point has converged when it moves less than ``tol`` (bandwidth units).

    Returns
    -------
    modes : (m, d) float
        Mean of the fixed points of each mode's members, in order of first appearance.
    labels : (n,) int
        Mode index of each point.
    """
    try:
        X = np.array(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ShapeError(f"points must be a float array of shape (n, d), got {points!r}") from exc
    if X.ndim != 2:
        raise ShapeError(f"points must have shape (n, d), got shape {X.shape}")
    if not np.all(np.isfinite(X)):
        raise NonFiniteError(f"points must be finite, got {X.tolist()}")
    n, d = X.shape
    H = np.array(bandwidth, dtype=np.float64)
    if H.ndim == 0:
        H = _bandwidth_matrix("bandwidth", bandwidth)[0, 0] * np.eye(d)
    elif d == 3:
        H = _bandwidth_matrix("bandwidth", bandwidth)
    elif H.shape != (d, d) or not np.all(np.isfinite(H)) or np.linalg.eigvalsh(H).min() <= 0:
        raise ShapeError(f"bandwidth must be a positive scalar or an SPD ({d}, {d}) matrix, got {H.tolist()}")
    if weights is None:
        w = np.ones(n)
    else:
        w = np.array(weights, dtype=np.float64)
        if w.shape != (n,):
            raise ShapeError(f"weights must have shape ({n},), got shape {w.shape}")
        if not np.all(np.isfinite(w)):
            raise NonFiniteError(f"weights must be finite, got {w.tolist()}")
        if np.any(w <= 0):
            raise NonPositiveSigmaError(f"weights must be > 0, got {w.tolist()}")
    if n == 0:
        return np.zeros((0, d)), np.zeros(0, dtype=np.int64)
    # Whiten so the kernel support is the unit ball.
    L = np.linalg.cholesky(H)
    Z = np.linalg.solve(L, X.T).T
    Y = Z.copy()
    active = np.ones(n, dtype=bool)
    for _ in range(int(max_iter)):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        Ya = Y[idx]
        d2 = np.sum((Ya[:, None, :] - Z[None, :, :]) ** 2, axis=2)
        W = (d2 < 1.0) * w[None, :]
        new = (W @ Z) / W.sum(axis=1, keepdims=True)
        moved = np.linalg.norm(new - Ya, axis=1)
        Y[idx] = new
        active[idx[moved < tol]] = False
    near = (np.sum((Y[:, None, :] - Y[None, :, :]) ** 2, axis=2) < MERGE_RADIUS**2).tolist()
    labels_list: list[int] = []
    reps: list[int] = []  # index of each mode's first member
    for i in range(n):
        row = near[i]
        for k, r in enumerate(reps):
            if row[r]:
                labels_list.append(k)
                break
        else:
            labels_list.append(len(reps))
            reps.append(i)
    labels = np.array(labels_list, dtype=np.int64)
    modes_z = np.array([Y[labels == k].mean(axis=0) for k in range(len(reps))])
    return modes_z @ L.T, labels


def _canonical_order(percepts: Sequence[Percept]) -> NDArray[np.int64]:
    pos = np.array([p.position for p in percepts]).reshape(-1, 3)
    sig = np.array([p.sigma for p in percepts])
    views = np.array([p.views for p in percepts])
    # np.lexsort sorts by the last key first.
    return np.lexsort((views, sig, pos[:, 2], pos[:, 1], pos[:, 0]))


def _melt(members: Sequence[Percept]) -> Percept:
    """One fused percept from a delineation set (inverse-information combination)."""
    X = np.array([p.position for p in members])
    C = np.array([p.covariance if p.covariance is not None else p.sigma**2 * np.eye(3) for p in members])
    info = np.linalg.inv(C)
    S = np.linalg.inv(info.sum(axis=0))
    m = S @ np.einsum("kij,kj->i", info, X)
    k = len(members)
    if k > 1:
        r = X - m
        chi2 = float(np.einsum("ki,kij,kj->", r, info, r))
        S = S * max(1.0, chi2 / (3.0 * (k - 1)))
    S = 0.5 * (S + S.T)
    rng = np.linalg.norm(m)
    sigma = float(np.sqrt(m @ S @ m) / rng) if rng > 0 else float(np.sqrt(np.trace(S) / 3.0))
    views = int(sum(p.views for p in members))
    return Percept(members[0].type, m, sigma, covariance=S, views=views)


def fuse_percepts(
    percepts: Sequence[Percept],
    *,
    bandwidth: float | ArrayLike | Mapping[str, float | ArrayLike] | None = None,
    min_views: int = 2,
    max_iter: int = 100,
    tol: float = 1e-6,
) -> list[Percept]:
    """Fuse raw percepts of several views into one percept per object (section 2.2).

    Per type, mean shift (:func:`mean_shift_modes`, Epanechnikov kernel, weights
    ``1 / sigma^2``) finds the modes; each mode's delineation set with at least ``min_views``
    raw views becomes one percept:

    - position: the inverse-covariance (information) weighted mean of the set (the
      ``1 / sigma^2``-weighted mean for isotropic percepts);
    - covariance: ``(sum C_i^-1)^-1``, inflated by ``chi^2 / dof`` when the set scatters more
      than its covariances explain (the Birge ratio), so inconsistent sets are not overconfident;
    - sigma: the standard deviation of the range, ``sqrt(u^T C u)`` with ``u`` the unit
      position vector;
    - views: the number of raw views in the set.

    The percepts are sorted canonically first, so the result does not depend on their order.

    Parameters
    ----------
    percepts : sequence of Percept
    bandwidth : float, (3, 3) float, or dict type -> float | (3, 3) float, optional
        Kernel radius in metres, or bandwidth matrix (e.g. a scaled
        :func:`perception.class_bandwidth`); default ``DEFAULT_BANDWIDTH``. A dict must name
        every type present.
    min_views : int
        Smallest delineation set kept (>= 1).
    max_iter, tol
        Mean-shift iteration limit and convergence threshold.

    Returns
    -------
    list of Percept
        Sorted by type, then by position.

    Raises
    ------
    UnknownClassError
        ``bandwidth`` is a dict without an entry for a type present.
    """
    ps = list(percepts)
    for i, p in enumerate(ps):
        if not isinstance(p, Percept):
            raise PerceptionError(f"percepts[{i}] must be a Percept, got {type(p).__name__}")
    if int(min_views) != min_views or min_views < 1:
        raise PerceptionError(f"min_views must be a positive integer, got {min_views!r}")
    types = sorted({p.type for p in ps})
    if isinstance(bandwidth, Mapping):
        missing = [t for t in types if t not in bandwidth]
        if missing:
            raise UnknownClassError(f"bandwidth has no entry for types {missing}; it has {sorted(bandwidth)}")
        H = {t: _bandwidth_matrix(f"bandwidth[{t!r}]", bandwidth[t]) for t in types}
    else:
        Hall = _bandwidth_matrix("bandwidth", DEFAULT_BANDWIDTH if bandwidth is None else bandwidth)
        H = dict.fromkeys(types, Hall)
    fused: list[Percept] = []
    for t in types:
        group = [p for p in ps if p.type == t]
        group = [group[i] for i in _canonical_order(group)]
        X = np.array([p.position for p in group])
        w = np.array([1.0 / p.sigma**2 for p in group])
        _, labels = mean_shift_modes(X, H[t], w, max_iter=max_iter, tol=tol)
        out = []
        for k in range(int(labels.max()) + 1):
            members = [group[i] for i in np.flatnonzero(labels == k)]
            if sum(p.views for p in members) >= min_views:
                out.append(_melt(members))
        out = [out[i] for i in _canonical_order(out)] if out else []
        fused += out
    return fused
