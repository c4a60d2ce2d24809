"""Weighted squared-range least squares (Beck, Stoica, Li 2008), solved globally.

:func:`srls` (re-exported by :mod:`radialopt.position`, the seed of its ``"ml"`` estimator and its
``"srls"`` method), the generalized trust-region subproblem ``_gtrs`` it reduces to, and
``_Frame``, the centred principal frame of the landmarks the estimators share.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import eigh
from scipy.optimize import brentq

from ._checks import MAX_SIGMA, real_array, real_scalar, sigma_range
from ._estimator_options import ESTIMATOR_OPTIONS
from .errors import RadialArgumentError
from .tolerances import POLE_OFFSET, RANK_RTOL, ROOT_XTOL


def _gtrs(a: NDArray, b: NDArray, w: NDArray) -> NDArray | None:
    """Global minimiser of ``sum w (|x - a_i|^2 - b_i)^2`` over x in R^d (d = 2 or 3).

    Written as ``min |W^1/2 (A y - beta)|^2`` s.t. ``y^T D y + 2 f^T y = 0`` with
    ``y = (x, |x|^2)``, a generalized trust-region subproblem; its solution is ``y(lam)`` at
    the root of the decreasing function ``phi(lam) = y^T D y + 2 f^T y`` on
    ``lam > -1 / mu_max`` (Beck, Stoica, Li 2008, Theorem 3.2).  Returns None when
    ``A^T W A`` is singular (centres not spanning R^d).
    """
    n, dim = a.shape
    A = np.hstack([-2.0 * a, np.ones((n, 1))])
    beta = b - np.einsum("ni,ni->n", a, a)
    M = A.T @ (w[:, None] * A)
    g = A.T @ (w * beta)
    D = np.diag(np.r_[np.ones(dim), 0.0])
    f = np.r_[np.zeros(dim), -0.5]
    try:
        ev = np.linalg.eigvalsh(M)
        if ev[0] <= RANK_RTOL * ev[-1]:
            return None
        mu, V = eigh(D, M)  # D V = M V diag(mu), V^T M V = I
    except np.linalg.LinAlgError:
        return None
    Vg, Vf = V.T @ g, V.T @ f

    def y_of(lam: float) -> NDArray:
        return V @ ((Vg - lam * Vf) / (1.0 + lam * mu))

    def phi(lam: float) -> float:
        y = y_of(lam)
        return float(y[:dim] @ y[:dim] - y[dim])

    mu_max = float(mu.max())
    lo = -1.0 / mu_max
    width = 1.0 / mu_max
    lo_in = lo + POLE_OFFSET * width
    if phi(lo_in) <= 0.0:  # hard case (or root next to the pole): take the boundary
        return y_of(lo_in)[:dim]
    hi = max(width, 1.0)
    for _ in range(200):
        if phi(hi) < 0.0:
            break
        hi *= 2.0
    else:
        return y_of(hi)[:dim]
    lam = brentq(phi, lo_in, hi, xtol=ROOT_XTOL * max(1.0, abs(hi)), rtol=4 * np.finfo(float).eps,
                 maxiter=500)
    return y_of(lam)[:dim]


@dataclass(frozen=True)
class _Frame:
    """Centred, scaled frame of the landmarks and their principal axes."""

    origin: NDArray[np.float64]
    spread: float
    axes: NDArray[np.float64]       # (3, 3) rows: principal directions, last = normal
    singular: NDArray[np.float64]   # (3,)

    @classmethod
    def of(cls, centers: NDArray) -> _Frame:
        origin = centers.mean(axis=0)
        cc = centers - origin
        _, sv, vt = np.linalg.svd(cc, full_matrices=True)
        sv = np.r_[sv, np.zeros(3 - len(sv))]
        spread = float(max(np.linalg.norm(cc, axis=1).max(), np.finfo(float).tiny))
        return cls(origin, spread, vt, sv)

    def rank(self, tol: float) -> int:
        return int(np.sum(self.singular > tol * max(self.singular[0], np.finfo(float).tiny)))

    def mirror(self, x: NDArray) -> NDArray:
        """Reflect points ``(m, 3)`` across the best-fit plane of the centres."""
        n = self.axes[2]
        return x - 2.0 * ((x - self.origin) @ n)[:, None] * n


def srls(centers: ArrayLike, radii: ArrayLike, sigmas: ArrayLike,
         rank_tol: float = ESTIMATOR_OPTIONS.rank_tol) -> NDArray[np.float64]:
    """Weighted squared-range least squares, solved globally.

    Parameters
    ----------
    centers : (n, 3) float
    radii, sigmas : (n,) float
    rank_tol : float
        Relative singular-value threshold for coplanar / collinear centres.

    Returns
    -------
    (k, 3) float
        One point when the centres span 3-D; with coplanar centres the two mirror images
        across their plane (one point when the solution lies on the plane); an empty
        ``(0, 3)`` array when the centres are collinear or fewer than three.
    """
    c = real_array("centers", centers, shape=(None, 3))
    r = real_array("radii", radii, shape=(len(c),), like="centers")
    s = real_array("sigmas", sigmas, shape=(len(c),), max_abs=MAX_SIGMA, like="centers")
    rank_tol = real_scalar("rank_tol", rank_tol, minimum=0.0, maximum=1.0)
    bad = np.flatnonzero(r < 0)
    if bad.size:
        raise RadialArgumentError(f"radii[{bad[0]}] = {float(r[bad[0]])!r} must be >= 0")
    if len(c):
        sigma_range("sigmas", s, max(float(np.abs(c).max()), float(r.max())))
    if len(c) < 3:
        return np.zeros((0, 3))
    frame = _Frame.of(c)
    rank = frame.rank(rank_tol)
    L = frame.spread
    local = (c - frame.origin) @ frame.axes.T / L  # principal coordinates, scaled
    rl, sl = r / L, s / L
    w = 1.0 / (4.0 * sl**2 * (rl**2 + sl**2))
    w = w / w.max()
    if rank == 3:
        x = _gtrs(local, rl**2, w)
        if x is None:
            return np.zeros((0, 3))
        return ((x @ frame.axes) * L + frame.origin)[None]
    if rank < 2:
        return np.zeros((0, 3))
    # coplanar: |x - c_i|^2 = |u - u_i|^2 + h^2 with u in the plane, h the height; the
    # relaxed problem is linear in (u, t = |u|^2 + h^2) and is exact when t >= |u|^2
    u_i = local[:, :2]
    A = np.hstack([-2.0 * u_i, np.ones((len(u_i), 1))])
    beta = rl**2 - np.einsum("ni,ni->n", u_i, u_i)
    sw = np.sqrt(w)
    sol, *_ = np.linalg.lstsq(A * sw[:, None], beta * sw, rcond=None)
    u, t = sol[:2], sol[2]
    h_sq = t - u @ u
    if h_sq <= 0.0:
        u2 = _gtrs(u_i, rl**2, w)
        if u2 is None:
            return np.zeros((0, 3))
        pts = np.array([[u2[0], u2[1], 0.0]])
    else:
        h = np.sqrt(h_sq)
        pts = np.array([[u[0], u[1], -h], [u[0], u[1], h]])
    return (pts @ frame.axes) * L + frame.origin
