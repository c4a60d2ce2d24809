"""The pure-Python core of ``method="active_set"`` for small instances (:mod:`radialopt.projection`).

Up to :data:`SMALL_CORE_SPHERES` spheres: Goldfarb and Idnani's dual active-set method on the
two-nonzero rows of the pairs (``_pair_rows``, ``_ldp_pairs``), in plain Python
(numpy's per-call cost dominates arrays this small), ending on a certified KKT point.
"""

from __future__ import annotations

import math
import operator

import numpy as np
from numpy.typing import NDArray

from .polytope import _SQRT_HALF
from .spheres import Tolerances, check_distinct_centers
from .tolerances import RANK_RTOL, ROUNDING_RTOL

#: Most spheres the pure-Python dual active-set core (``_ldp_pairs``) handles; beyond it the
#: NNLS route (:func:`least_distance`) runs.  At these sizes numpy's per-call cost outweighs the
#: arithmetic, a few hundred flops (docs/design.md#defaults).
SMALL_CORE_SPHERES = 8

_Q = float(_SQRT_HALF)  # a Python float: numpy scalars are slow in plain arithmetic

_PairRows = list[tuple[int, int, float, float, float]]
"""Whitened rows ``(i, j, g_i, g_j, h)`` of ``G z <= h``: each restriction row has two nonzeros."""


def _pair_rows(
    centers: list[list[float]], radii: list[float], sigmas: list[float], tol: Tolerances,
    centers_array: NDArray[np.float64],
) -> tuple[_PairRows, list[float]]:
    """The whitened restriction rows of every pair (chi, alpha, beta, as :func:`pair_pattern`)
    and the centre distances, in plain Python; :class:`RadialError` for a pair
    closer than ``tol.coincident``."""
    rows, dist, _ = _pair_setup(centers, radii, sigmas, tol, centers_array)
    return rows, dist


_PairSetup = tuple[list[float], list[tuple[int, int, float, float, float]]]
"""``(|g_i| per sphere, (i, j, h_chi, h_alpha, h_beta) per pair)``: ``_ldp_pairs`` evaluates
``G z - h`` per pair from them."""


def _pair_setup(
    centers: list[list[float]], radii: list[float], sigmas: list[float], tol: Tolerances,
    centers_array: NDArray[np.float64],
) -> tuple[_PairRows, list[float], _PairSetup]:
    """``_pair_rows`` and, from the same pass, the per-pair form ``_ldp_pairs`` uses."""
    q = _Q
    n = len(radii)
    coincident = tol.coincident
    rows: _PairRows = []
    dist: list[float] = []
    pairs = []
    gs = [q * sg for sg in sigmas]
    for i in range(n - 1):
        xi, yi, zi = centers[i]
        ri, gi = radii[i], gs[i]
        for j in range(i + 1, n):
            xj, yj, zj = centers[j]
            d = math.sqrt((xi - xj) ** 2 + (yi - yj) ** 2 + (zi - zj) ** 2)
            if d <= coincident:
                check_distinct_centers(centers_array, tol)  # raises, naming the pair
            dist.append(d)
            rj, gj, qd = radii[j], gs[j], q * d
            h0, h1, h2 = -qd + q * (ri + rj), qd - q * (rj - ri), qd - q * (ri - rj)
            rows += ((i, j, -gi, -gj, h0),  # chi: -r_i - r_j <= -d
                     (i, j, -gi, gj, h1),   # alpha: r_j - r_i <= d
                     (i, j, gi, -gj, h2))   # beta: r_i - r_j <= d
            pairs.append((i, j, h0, h1, h2))
    return rows, dist, (gs, pairs)


def _chol_solve(M: list[list[float]], rhs: list[float]) -> list[float] | None:
    """Solve the small symmetric positive definite system ``M x = rhs`` (Cholesky, plain
    Python); None when M is not numerically positive definite."""
    k = len(rhs)
    if k == 1:
        return [rhs[0] / M[0][0]] if M[0][0] > 0.0 else None
    if k == 2:  # the same test as the Cholesky pivot below, in closed form
        m00, m01, m11 = M[0][0], M[0][1], M[1][1]
        det = m00 * m11 - m01 * m01
        if not (m00 > 0.0 and det > RANK_RTOL * m00 * m11):
            return None
        return [(m11 * rhs[0] - m01 * rhs[1]) / det, (m00 * rhs[1] - m01 * rhs[0]) / det]
    L = [[0.0] * k for _ in range(k)]
    for a in range(k):
        La = L[a]
        for c in range(a + 1):
            Lc = L[c]
            s = M[a][c]
            for t in range(c):
                s -= La[t] * Lc[t]
            if a == c:
                if not s > RANK_RTOL * M[a][a]:
                    return None
                La[a] = math.sqrt(s)
            else:
                La[c] = s / Lc[c]
    y = list(rhs)
    for a in range(k):
        s = y[a]
        for t in range(a):
            s -= L[a][t] * y[t]
        y[a] = s / L[a][a]
    for a in range(k - 1, -1, -1):
        s = y[a]
        for t in range(a + 1, k):
            s -= L[t][a] * y[t]
        y[a] = s / L[a][a]
    return y


def _dot(a: list[float], b: list[float]) -> float:
    return sum(map(operator.mul, a, b))


def _ldp_pairs(rows: _PairRows, n: int, setup: _PairSetup | None = None
               ) -> tuple[list[float], list[float]] | None:
    """``min |z|^2 s.t. G z <= h`` for two-nonzero rows: Goldfarb and Idnani's dual active-set
    method (Math. Programming 27, 1983) with the identity Hessian, in plain Python.

    From ``z = 0`` the most violated row joins the working set; on the way its multiplier
    grows, the working rows' multipliers change along ``-r`` and ``z`` moves along the
    projection of the row's normal onto the working rows' null space; a working row whose
    multiplier reaches zero first leaves (partial step).  The working rows stay independent,
    so each step solves a positive definite system of at most n rows (Cholesky).  The
    multipliers stay >= 0 by construction, so the loop ends on a KKT point: it stops when no
    row is violated by more than ``tol = ROUNDING_RTOL * max(|h|, 1)`` (the test of
    ``_polish_certified``), and the answer is returned only then with every multiplier
    >= -tol.

    Returns ``(z, G z - h)`` at the optimum, or None when it did not settle, met a violated row dependent
    on the working rows (the sign of infeasibility) or a singular working set: the caller then
    runs the NNLS route, which decides.
    """
    excess = [-row[4] for row in rows]  # G z - h at z = 0
    tol = ROUNDING_RTOL * max(max(excess), -min(excess), 1.0)
    # the rows come in triples (chi, alpha, beta) per pair, with |g_i| = sigma_i / sqrt 2, so
    # G z - h is evaluated per pair from v_i = |g_i| z_i (the same products as row by row)
    if setup is None:
        gs = [0.0] * n
        pairs = []
        for k in range(0, len(rows), 3):
            i, j, a, b, h0 = rows[k]
            gs[i], gs[j] = -a, -b
            pairs.append((i, j, h0, rows[k + 1][4], rows[k + 2][4]))
    else:
        gs, pairs = setup
    z = [0.0] * n
    act: list[tuple[int, int, float, float]] = []  # working rows (i, j, g_i, g_j)
    gram: list[list[float]] = []
    u: list[float] = []
    for _ in range(2 * len(rows) + 2):
        worst = max(excess)
        if worst <= tol:
            return (z, excess) if min(u, default=0.0) >= -tol else None
        p = excess.index(worst)
        i, j, a, b, hk = rows[p]
        gp_sq = a * a + b * b
        up = 0.0
        for _inner in range(n + 2):
            if not act:  # an empty working set: the full step along gp (two nonzeros)
                t = (a * z[i] + b * z[j] - hk) / gp_sq
                z = list(z)
                z[i] -= t * a
                z[j] -= t * b
                up += t
                gram = [[gp_sq]]
                act.append((i, j, a, b))
                u = [up]
                break
            if act:
                r = _chol_solve(gram, [(a * ga if ia == i else a * gb if ja == i else 0.0)
                                       + (b * ga if ia == j else b * gb if ja == j else 0.0)
                                       for ia, ja, ga, gb in act])
                if r is None:
                    return None
                w = [0.0] * n  # gp projected onto the working rows' null space
                w[i] = a
                w[j] = b
                for rk, (ia, ja, ga, gb) in zip(r, act, strict=True):
                    w[ia] -= rk * ga
                    w[ja] -= rk * gb
            else:
                r = []
                w = [0.0] * n
                w[i] = a
                w[j] = b
            gd = _dot(w, w)
            t1, kd = math.inf, -1
            for k, rk in enumerate(r):
                if rk > 0.0 and u[k] / rk < t1:
                    t1, kd = u[k] / rk, k
            dependent = gd <= RANK_RTOL * gp_sq
            if dependent and kd < 0:  # a violated row in the working rows' cone: let NNLS decide
                return None
            t2 = math.inf if dependent else (a * z[i] + b * z[j] - hk) / gd
            t = min(t1, t2)
            if not dependent:
                z = [zt - t * wt for zt, wt in zip(z, w, strict=True)]
            u = [uk - t * rk for uk, rk in zip(u, r, strict=True)]
            up += t
            if t2 <= t1:  # full step: the row joins the working set
                col = [(a * ga if ia == i else a * gb if ja == i else 0.0)
                       + (b * ga if ia == j else b * gb if ja == j else 0.0) for ia, ja, ga, gb in act]
                gram = [row + [c] for row, c in zip(gram, col, strict=True)]
                gram.append(col + [gp_sq])
                act.append((i, j, a, b))
                u.append(up)
                break
            del act[kd], u[kd], gram[kd]  # partial step: row kd leaves
            for row in gram:
                del row[kd]
        else:
            return None
        v = [g * zt for g, zt in zip(gs, z, strict=True)]
        excess = []
        for i, j, h0, h1, h2 in pairs:
            vi, vj = v[i], v[j]
            excess += (-vi - vj - h0, vj - vi - h1, vi - vj - h2)
    return None
