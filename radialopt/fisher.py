"""Fisher information and the Cramer-Rao bound of a position from ranges.

:func:`fisher_information` and :func:`crlb` (``J = sum_i u_i u_i^T / sigma_i^2`` with ``u_i``
the unit vector from centre i to the position); :mod:`radialopt.position` re-exports both and
gives every estimate the bound as its covariance.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._checks import MAX_SIGMA, point3, real_array, real_scalar, sigma_range
from ._estimator_options import ESTIMATOR_OPTIONS
from .errors import RadialArgumentError, SingularFisherError
from .tolerances import FISHER_SINGULAR, ON_CENTRE_RTOL

__all__ = ["crlb", "fisher_information"]


def _check_crlb_input(centers: ArrayLike, sigmas: ArrayLike, position: ArrayLike
                      ) -> tuple[NDArray, NDArray, NDArray]:
    c = real_array("centers", centers, shape=(None, 3))
    if len(c) == 0:
        raise RadialArgumentError("centers must hold at least one centre, got shape (0, 3)")
    s = real_array("sigmas", sigmas, shape=(len(c),), max_abs=MAX_SIGMA, like="centers")
    x = point3("position", position)
    sigma_range("sigmas", s, max(float(np.abs(c).max()), float(np.abs(x).max())))
    return c, s, x


def fisher_information(centers: ArrayLike, sigmas: ArrayLike, position: ArrayLike
                       ) -> NDArray[np.float64]:
    """Fisher information of the position from ranges, ``J = sum_i u_i u_i^T / sigma_i^2``.

    Parameters
    ----------
    centers : (n, 3) float
    sigmas : (n,) float
    position : (3,) float

    Returns
    -------
    (3, 3) float

    Raises
    ------
    SingularFisherError
        The position coincides with a centre (the range is not differentiable there).
    """
    c, s, x = _check_crlb_input(centers, sigmas, position)
    u = _unit_directions(c, x)
    return np.einsum("ni,nj->ij", u / s[:, None] ** 2, u)


def _unit_directions(c: NDArray, x: NDArray) -> NDArray:
    """Unit vectors ``(n, 3)`` from the centres to ``x``; raises where ``x`` is on a centre."""
    diff = x - c
    d = np.linalg.norm(diff, axis=1)
    scale = max(float(np.max(np.abs(c - c.mean(axis=0)), initial=0.0)), 1.0)
    if np.any(d <= ON_CENTRE_RTOL * scale):
        i = int(np.argmin(d))
        raise SingularFisherError(f"position {x.tolist()} coincides with centre {i} "
                                  f"({c[i].tolist()}): the range is not differentiable there")
    return diff / d[:, None]


def crlb(centers: ArrayLike, sigmas: ArrayLike, position: ArrayLike,
         rcond: float = ESTIMATOR_OPTIONS.fisher_rcond) -> NDArray[np.float64]:
    """Cramer-Rao bound ``J^-1`` of the position (covariance of an efficient estimator).

    Parameters
    ----------
    centers : (n, 3) float
        Landmark positions.
    sigmas : (n,) float
        Standard deviations of the ranges.
    position : (3,) float
        Where to evaluate the bound (the truth, or an estimate).
    rcond : float
        Singularity threshold on the smallest eigenvalue of ``sum_i u_i u_i^T / n``
        (geometry only: it does not depend on the sigmas).

    Returns
    -------
    (3, 3) float

    Raises
    ------
    SingularFisherError
        Some direction is unobservable: fewer than three directions, all directions
        ``u_i`` in a plane (the position on the plane of coplanar centres) or on a line.
    """
    c, s, x = _check_crlb_input(centers, sigmas, position)
    rcond = real_scalar("rcond", rcond, minimum=0.0, maximum=1.0)
    u = _unit_directions(c, x)
    J = np.einsum("ni,nj->ij", u / s[:, None] ** 2, u)
    geometric = np.linalg.eigvalsh(u.T @ u / len(u))
    if geometric[0] <= rcond:
        raise SingularFisherError(
            f"Fisher information at position = {x.tolist()} is singular: the directions from it to the "
            f"{len(c)} centers span too few dimensions (smallest eigenvalue {geometric[0]:.3g} <= "
            f"{rcond:g}); centers = {c.tolist()!r:.300}")
    w, V = np.linalg.eigh(J)
    if not (np.all(np.isfinite(w)) and w[0] > FISHER_SINGULAR * w[-1]):
        raise SingularFisherError(
            f"Fisher information at position = {x.tolist()} is numerically singular: eigenvalues "
            f"{w.tolist()} (condition beyond 1e13; sigmas span {float(s.min()):.3g} to "
            f"{float(s.max()):.3g} m); centers = {c.tolist()!r:.300}")
    return (V / w) @ V.T
