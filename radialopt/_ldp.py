"""Least-distance programming for :mod:`radialopt.projection`: ``min |z|^2 s.t. G z <= h``.

Lawson and Hanson's route (Solving Least Squares Problems, 1974, ch. 23): a non-negative least
squares problem solved by :func:`scipy.optimize.nnls`, then an exact equality-constrained polish
on the active rows with a KKT check (:func:`least_distance`, ``_polish_certified``).  It is
the ``"active_set"`` method beyond :data:`~radialopt.projection.SMALL_CORE_SPHERES` spheres (and
when the small core does not certify); the cvxpy path reuses the polish.
"""

from __future__ import annotations

from typing import cast

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import nnls

from .tolerances import FARKAS_LAST_ZERO, FARKAS_ZERO, RANK_RTOL, ROUNDING_RTOL


def least_distance(G: NDArray[np.float64], h: NDArray[np.float64]) -> tuple[NDArray[np.float64], str]:
    """Solve ``min |z|^2 subject to G z <= h`` exactly (Lawson-Hanson LDP via NNLS, then polish).

    Returns ``(z, status)`` with status ``"optimal"`` or ``"infeasible"``.

    With many more rows than :data:`CONSTRAINT_GENERATION_ROWS` (every pair of many spheres) the
    rows are generated: solve on the rows violated so far, add every row the answer violates,
    repeat.  The answer of a subset that violates no row of the whole is the whole's optimum
    (its feasible set contains the whole's), so this is exact; an infeasible subset means an
    infeasible whole.
    """
    n = G.shape[1]
    if h.min() >= 0:
        return np.zeros(n), "optimal"
    if G.shape[0] > CONSTRAINT_GENERATION_ROWS:
        tol = ROUNDING_RTOL * max(float(np.abs(h).max()), 1.0)
        rows = np.flatnonzero(h < 0)
        for _ in range(G.shape[0]):
            z, status = _least_distance_dense(G[rows], h[rows])
            if status != "optimal":
                return z, status
            viol = np.flatnonzero(G @ z - h > tol)
            new = np.setdiff1d(viol, rows, assume_unique=True)
            if new.size == 0:
                return z, status
            rows = np.union1d(rows, new)
        return _least_distance_dense(G, h)
    return _least_distance_dense(G, h)


#: Row count above which :func:`least_distance` generates its rows instead of passing all.
CONSTRAINT_GENERATION_ROWS = 200


def _least_distance_dense(G: NDArray[np.float64], h: NDArray[np.float64]) -> tuple[NDArray[np.float64], str]:
    """:func:`least_distance` on every row at once (NNLS, then the exact polish)."""
    n = G.shape[1]
    if h.min() >= 0:
        return np.zeros(n), "optimal"
    # LDP in Lawson-Hanson form: min |z| s.t. E z >= f with E = -G, f = -h.
    M = np.empty((n + 1, G.shape[0]))
    np.negative(G.T, out=M[:n])
    np.negative(h, out=M[n])
    e = np.zeros(n + 1)
    e[n] = 1.0
    u, _ = nnls(M, e, maxiter=50 * M.shape[1])
    resid = M @ u - e
    if abs(resid[n]) <= FARKAS_LAST_ZERO or np.linalg.norm(resid) <= FARKAS_ZERO:
        return np.full(n, np.nan), "infeasible"
    z = -resid[:n] / resid[n]
    return _polish(G, h, z, u > 0), "optimal"


def _polish(
    G: NDArray[np.float64], h: NDArray[np.float64], z: NDArray[np.float64], support: NDArray[np.bool_]
) -> NDArray[np.float64]:
    """Finish exactly: an active-set loop on ``min |z|^2 s.t. G_S z = h_S`` seeded by NNLS.

    On a working set S the answer is ``z = -G_S^T y`` with ``(G_S G_S^T) y = -h_S`` and KKT
    multipliers ``y >= 0``.  Rows with a negative multiplier leave S, the most violated row
    joins it; at most a few steps are needed from the NNLS support.  Falls back to the NNLS
    answer if the loop does not settle.
    """
    if not np.any(support):
        return z
    return _polish_certified(G, h, z, support)[0]


def _polish_certified(
    G: NDArray[np.float64], h: NDArray[np.float64], z: NDArray[np.float64], support: NDArray[np.bool_]
) -> tuple[NDArray[np.float64], bool]:
    """``_polish`` that also says whether it ended on a KKT point: ``(z, True)`` when the
    returned ``z`` has multipliers ``>= 0`` on its working set and violates no row (to 1e-12
    of ``max|h|``), ``(z_in, False)`` when the loop did not settle.  An empty support with a
    feasible origin is the KKT point ``z = 0``."""
    tol = ROUNDING_RTOL * max(float(np.abs(h).max()), 1.0)
    work = np.flatnonzero(support).tolist()
    if not work:
        work = [int(np.argmax(G @ np.zeros(G.shape[1]) - h))]
        if h[work[0]] >= 0:
            return np.zeros(G.shape[1]), True
    for _ in range(2 * G.shape[0]):
        GS = G[work]
        y = _solve_small(GS @ GS.T, -h[work])
        k = int(np.argmin(y))
        if y[k] < -tol:
            del work[k]
            if not work:
                return z, False
            continue
        z2 = -(y @ GS)
        viol = G @ z2 - h
        j = int(np.argmax(viol))
        if viol[j] > tol:
            if j in work:
                return z, False
            work.append(j)
            continue
        return z2, True
    return z, False


def _solve_small(M: NDArray[np.float64], rhs: NDArray[np.float64]) -> NDArray[np.float64]:
    """Solve a small symmetric system; closed form for 1x1 and 2x2 (numpy's per-call overhead
    dominates there), least squares when the active rows are dependent (degenerate vertex)."""
    k = len(rhs)
    if k == 1 and M[0, 0] > 0:
        return rhs / M[0, 0]
    if k == 2:
        det = M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]
        if abs(det) > RANK_RTOL * (M[0, 0] * M[1, 1]):
            return np.array([M[1, 1] * rhs[0] - M[0, 1] * rhs[1],
                             M[0, 0] * rhs[1] - M[1, 0] * rhs[0]], dtype=np.float64) / float(det)
    # numpy's stubs widen float64 results of linalg to floating[Any]
    try:
        return cast(NDArray[np.float64], np.linalg.solve(M, rhs))
    except np.linalg.LinAlgError:
        return cast(NDArray[np.float64], np.linalg.lstsq(M, rhs, rcond=None)[0])
