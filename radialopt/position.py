"""Position estimation from Gaussian spheres (paper sections 2.3, 4.1-4.5; docs/design.md#m7, #m8).

Maximising the total density eq. 20 over the position x is sigma-weighted range least
squares: minimise ``sum_i ((|x - X_i| - r_i) / sigma_i)^2``.  Four estimators share one entry
point, :func:`estimate_position`:

``"ml"`` (default)
    The maximum of eq. 20: weighted SR-LS (global, below) as a seed, Levenberg-Marquardt on
    the sigma-weighted residuals from that seed, from its mirror images across the planes of
    landmark triples and the best-fit plane of the landmarks, from the points of every
    sphere triple (the paper's ``Phi_2``) and from the paper's estimate; the best is kept.
    Its density is never below the paper's (the paper's estimate is one of the candidates).
    The best few LM results are then polished by a trust-region least-squares solve
    (:func:`scipy.optimize.least_squares`, ``"trf"``, ``x_scale="jac"``) in a chart about the
    centre of the most precise sphere, where its thin curved valley is straight;
    the chosen point is polished once more and the status is ``"not_converged"`` when that
    solve stops at its evaluation cap instead of a tolerance.
``"srls"``
    Weighted squared-range least squares alone (Beck, Stoica, Li 2008): minimise
    ``sum_i w_i (|x - X_i|^2 - r_i^2)^2`` with ``w_i = 1 / (4 sigma_i^2 (r_i^2 + sigma_i^2))``
    (the first-order variance of ``r_i^2``), solved globally as a generalized trust-region
    subproblem by a 1-D root search on its multiplier.
``"paper"``
    The paper's pipeline: normalised radial projection (adjusted radii, eq. 16-19), then the
    meet of the adjusted spheres (radical centre of four, point pair of three), the
    hypothesis level sets for more spheres, the candidate of highest total density.
``"gradient"``
    Eq. 15: multi-seed fixed-step gradient ascent on the (log) product density, the iterative
    baseline the paper argues against.  Step ``1 / sum_i sigma_i^-2`` (the inverse of an
    upper bound of the curvature near the spheres' surfaces), each step capped at a tenth of
    the landmark spread, at most ``EstimatorOptions.gradient_max_iter`` iterations.

The covariance of every estimate is the Cramer-Rao bound ``J^-1``, ``J = sum_i u_i u_i^T /
sigma_i^2`` with ``u_i`` the unit vector from centre i to the position (:func:`crlb`).

Degenerate input never raises from inside numpy: fewer than three spheres, collinear centres
and a position on the plane of coplanar centres give a status and a message.  With coplanar
centres the mirror image of every candidate across that plane has the same density: both are
returned and the status is ``"ambiguous"`` unless the region keeps only one.

:class:`EstimatorOptions` lives in ``radialopt._estimator_options``, :func:`fisher_information`
and :func:`crlb` in :mod:`radialopt.fisher`, :func:`srls` in ``radialopt._srls``; this module
imports and re-exports them.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from itertools import combinations
from typing import Literal, get_args

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares
from scipy.spatial import cKDTree

from ._checks import instance
from ._estimator_options import ESTIMATOR_OPTIONS, EstimatorOptions
from ._srls import _Frame, srls
from .certificates import Certificate, certify_arrays
from .conformal import MeetStatus, meet3_batch
from .errors import (
    RadialArgumentError,
    SingularFisherError,
    SolverError,
)
from .fisher import crlb, fisher_information
from .hypotheses import Region, generate_hypotheses
from .spheres import GaussianSphere, sphere_arrays
from .tolerances import (
    COLLINEAR_RTOL,
    CONVEXITY_RTOL,
    LM_DAMPING_MIN,
    LM_DAMPING_START,
    POLISH_TOL,
    ROUNDING_RTOL,
    TINY,
)

__all__ = [
    "ESTIMATOR_OPTIONS",
    "POSITION_METHODS",
    "POSITION_STATUSES",
    "POSITION_SUCCESS",
    "PositionStatus",
    "PositionSuccess",
    "EstimatorOptions",
    "PositionEstimate",
    "crlb",
    "estimate_position",
    "fisher_information",
    "srls",
]

#: Statuses whose position is a usable answer (finite, converged, near the landmarks and inside
#: the ``region`` when one is given).  ``"outside_region"`` is not one: its position violates the
#: caller's region (worldgraph's ``localize`` treats it as a failure too).
PositionSuccess = Literal[
    "ok",                    # a unique estimate
    "ambiguous",             # another candidate is about as likely (mirror image, ...)
]
#: Statuses of :class:`PositionEstimate`.
PositionStatus = Literal[
    PositionSuccess,
    "outside_region",        # no candidate inside the region; the best one (outside it) is
                             # returned for diagnosis: not a success (it violates the region)
    "degenerate_coplanar",   # coplanar centres and the estimate on their plane: J singular
    "degenerate_collinear",  # collinear centres: the position is only known up to a circle
    "too_few_spheres",       # fewer than three spheres
    "degenerate",            # J singular at the estimate (e.g. on a centre), or the estimate lies
                             # more than max_range_ratio spreads from the centres (range scale
                             # inconsistent with the landmarks): no usable position
    "not_converged",         # "ml" polish or "gradient" ascent hit its cap: best point found
]
POSITION_STATUSES: tuple[str, ...] = get_args(PositionStatus)
#: ``"ok"`` and ``"ambiguous"`` (:data:`PositionSuccess`).
POSITION_SUCCESS: tuple[str, ...] = get_args(PositionSuccess)


@dataclass(frozen=True)
class PositionEstimate:
    """Result of :func:`estimate_position`.

    Attributes
    ----------
    position : (3,) float
        The estimate (NaN when the status is ``"too_few_spheres"`` or
        ``"degenerate_collinear"``).
    covariance : (3, 3) float
        Cramer-Rao bound at the estimate (``inf`` everywhere when J is singular).
    candidates : (k, 3) float
        Distinct candidates, the chosen one first, then inside-region before outside, by
        decreasing density.
    density : float
        Total density eq. 20 at ``position``.
    method : str
    status : str
        One of :data:`POSITION_STATUSES`.
    message : str
        Explanation of a status other than ``"ok"``.
    candidate_density : (k,) float
        Density of each candidate.
    solve_time : float
        Seconds.
    certificate : Certificate or None
        With ``certify=True``: the proof (or failed attempt) that ``position`` minimises the
        ML cost globally (:func:`radialopt.certify_position`); None otherwise.
    """

    position: NDArray[np.float64]
    covariance: NDArray[np.float64]
    candidates: NDArray[np.float64]
    density: float
    method: str
    status: str
    message: str = ""
    candidate_density: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    solve_time: float = 0.0
    certificate: Certificate | None = None


# --- residuals, Levenberg-Marquardt, gradient ascent (all batched over seeds) --------------

def _residuals(x: NDArray, c: NDArray, r: NDArray, s: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Normalised residuals ``(m, n)``, their Jacobian ``(m, n, 3)`` and costs ``(m,)``."""
    diff = x[:, None, :] - c[None]
    d = np.linalg.norm(diff, axis=2)
    res = (d - r) / s
    jac = diff / (np.maximum(d, np.finfo(float).tiny) * s)[..., None]
    return res, jac, np.einsum("mn,mn->m", res, res)


def _costs(x: NDArray, c: NDArray, r: NDArray, s: NDArray) -> NDArray:
    d = np.linalg.norm(x[:, None, :] - c[None], axis=2)
    z = (d - r) / s
    return np.einsum("mn,mn->m", z, z)


def _levenberg_marquardt(x0: NDArray, c: NDArray, r: NDArray, s: NDArray, spread: float,
                         opts: EstimatorOptions) -> tuple[NDArray, NDArray]:
    """Minimise the sigma-weighted range cost from every seed at once.

    Returns the final points ``(m, 3)`` and costs ``(m,)``.  Each step solves
    ``(H + mu tr(J^T J)/3 I) dx = -J^T res`` where H is the exact Hessian of the half cost,
    ``J^T J + sum_i res_i / (sigma_i d_i) (I - u_i u_i^T)``, when it is positive definite
    (always near a minimum: quadratic convergence even with large residuals, where plain
    Gauss-Newton crawls) and the Gauss-Newton matrix ``J^T J`` otherwise.  Accepted steps
    shrink mu, rejected ones grow it, so the cost never increases.
    """
    x = x0.copy()
    res, jac, cost = _residuals(x, c, r, s)
    mu = np.full(len(x), LM_DAMPING_START)
    active = np.ones(len(x), dtype=bool)
    eye = np.eye(3)
    tiny = np.finfo(float).tiny
    for _ in range(opts.lm_max_iter):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        J, e = jac[idx], res[idx]
        A = np.einsum("mni,mnj->mij", J, J)
        g = np.einsum("mni,mn->mi", J, e)
        u = J * s[:, None]
        w = e / (s * np.maximum(e * s + r, tiny))  # res_i / (sigma_i d_i)
        H = A + w.sum(axis=1)[:, None, None] * eye - np.einsum("mn,mni,mnj->mij", w, u, u)
        scale = np.maximum(np.trace(A, axis1=1, axis2=2) / 3.0, tiny)
        convex = np.linalg.eigvalsh(H)[:, 0] > CONVEXITY_RTOL * scale
        M = np.where(convex[:, None, None], H, A)
        step = -np.linalg.solve(M + (mu[idx] * scale)[:, None, None] * eye, g[..., None])[..., 0]
        xn = x[idx] + step
        rn, jn, cn = _residuals(xn, c, r, s)
        better = cn <= cost[idx]
        acc = idx[better]
        x[acc], res[acc], jac[acc], cost[acc] = xn[better], rn[better], jn[better], cn[better]
        mu[acc] = np.maximum(mu[acc] * 0.1, LM_DAMPING_MIN)
        rej = idx[~better]
        mu[rej] *= 10.0
        # converged: a step below the tolerance that did not raise the cost beyond rounding
        small = np.linalg.norm(step, axis=1) <= opts.lm_step_tol * spread
        flat = cn <= cost[idx] * (1.0 + ROUNDING_RTOL) + TINY
        done = (small & flat) | (mu[idx] > 1e12) | (better & (cn == 0.0))
        active[idx[done]] = False
    return x, cost


def _gradient_ascent(x0: NDArray, c: NDArray, r: NDArray, s: NDArray, spread: float,
                     opts: EstimatorOptions) -> NDArray:
    """Eq. 15 by fixed-step ascent on the log of eq. 14 (same maximiser, usable gradient)."""
    x = x0.copy()
    step_size = 1.0 / np.sum(1.0 / s**2)
    max_len = 0.1 * spread
    for _ in range(opts.gradient_max_iter):
        res, jac, _ = _residuals(x, c, r, s)
        # d/dx log f = -sum_i (d_i - r_i) / sigma_i^2 u_i  (jac = u / sigma, res = (d - r) / sigma)
        grad_log = -np.einsum("mni,mn->mi", jac, res)
        step = step_size * grad_log
        length = np.linalg.norm(step, axis=1)
        step *= np.minimum(1.0, max_len / np.maximum(length, np.finfo(float).tiny))[:, None]
        x += step
        if np.all(length <= opts.gradient_step_tol * spread):
            break
    return x


# --- the estimators ----------------------------------------------------------------------

@dataclass(frozen=True)
class _Data:
    centers: NDArray[np.float64]
    radii: NDArray[np.float64]
    sigmas: NDArray[np.float64]
    frame: _Frame
    rank: int


def _generation_subset(sigmas: NDArray, limit: int) -> NDArray[np.intp]:
    """Indices of the ``limit`` spheres of smallest sigma (ties by index), increasing."""
    if len(sigmas) <= limit:
        return np.arange(len(sigmas))
    return np.sort(np.argsort(sigmas, kind="stable")[:limit])


def _triples(d: _Data, limit: int) -> NDArray[np.intp]:
    """Sphere triples ``(t, 3)`` among the generation subset."""
    return np.array(list(combinations(_generation_subset(d.sigmas, limit).tolist(), 3)), dtype=np.intp)


def _triple_points(d: _Data, limit: int) -> NDArray:
    """Points of every sphere triple (the paper's Phi_2, imaginary pairs by their foot)."""
    triples = _triples(d, limit)
    pb = meet3_batch(d.centers[triples], d.radii[triples] ** 2)
    ok = pb.status <= MeetStatus.IMAGINARY
    return pb.points[ok].reshape(-1, 3)


def _triple_mirrors(d: _Data, x: NDArray, limit: int) -> NDArray:
    """Reflections of points ``(m, 3)`` across the plane of every landmark triple and the
    best-fit plane of the landmarks."""
    triples = _triples(d, limit)
    p0 = d.centers[triples[:, 0]]
    nrm = np.cross(d.centers[triples[:, 1]] - p0, d.centers[triples[:, 2]] - p0)
    length = np.linalg.norm(nrm, axis=1)
    keep = length > COLLINEAR_RTOL * d.frame.spread**2
    p0, nrm = p0[keep], nrm[keep] / length[keep, None]
    h = np.einsum("mtk,tk->mt", x[:, None, :] - p0[None], nrm)  # (m, t)
    out = x[:, None, :] - 2.0 * h[..., None] * nrm[None]
    return np.vstack([out.reshape(-1, 3), d.frame.mirror(x)])


def _random_seeds(d: _Data, rng: np.random.Generator | None, region: Region | None,
                  count: int) -> NDArray:
    if rng is None or count <= 0:
        return np.zeros((0, 3))
    if region is not None:
        lo, hi = region.lower, region.upper
    else:
        lo = d.centers.min(axis=0) - 0.5 * d.frame.spread
        hi = d.centers.max(axis=0) + 0.5 * d.frame.spread
    return rng.uniform(lo, hi, size=(count, 3))


def _paper_candidates(spheres: Sequence[GaussianSphere], d: _Data, region: Region | None,
                      limit: int) -> NDArray:
    # imported where used: only "paper" and "ml" need it; the unchecked route, since
    # estimate_position checked the spheres (sphere_arrays) before any method runs
    from .projection import project_radii_unchecked

    keep = _generation_subset(d.sigmas, limit)
    spheres = [spheres[i] for i in keep]
    sol = project_radii_unchecked(d.centers[keep], d.radii[keep], d.sigmas[keep], method="active_set")
    adjusted = [s.with_radius(max(float(r), 0.0)) for s, r in zip(spheres, sol.radii, strict=True)]
    return generate_hypotheses(adjusted, region=region, keep_imaginary=True).positions


def _method_paper(spheres: Sequence[GaussianSphere], d: _Data, region: Region | None,
                  rng: np.random.Generator | None, opts: EstimatorOptions) -> NDArray:
    return _paper_candidates(spheres, d, region, opts.max_generation_spheres)


def _method_srls(spheres: Sequence[GaussianSphere], d: _Data, region: Region | None,
                 rng: np.random.Generator | None, opts: EstimatorOptions) -> NDArray:
    return srls(d.centers, d.radii, d.sigmas, opts.rank_tol)


def _method_ml(spheres: Sequence[GaussianSphere], d: _Data, region: Region | None,
               rng: np.random.Generator | None, opts: EstimatorOptions) -> NDArray:
    seed = srls(d.centers, d.radii, d.sigmas, opts.rank_tol)
    try:
        paper = _paper_candidates(spheres, d, region, opts.max_generation_spheres)
    except SolverError:
        paper = np.zeros((0, 3))
    # the paper's candidates (unrefined) stay in the pool, so ML never ends below them
    limit = opts.max_generation_spheres
    seeds = np.vstack([seed, _triple_mirrors(d, seed, limit) if len(seed) else np.zeros((0, 3)),
                       _triple_points(d, limit), paper,
                       _random_seeds(d, rng, region, opts.random_seeds)])
    seeds = seeds[np.all(np.isfinite(seeds), axis=1)]
    x, cost = _levenberg_marquardt(seeds, d.centers, d.radii, d.sigmas, d.frame.spread, opts)
    top, _ = _distinct(x, cost, opts.distinct_tol * d.frame.spread)
    polished, _ = _chart_polish(top[:opts.polish_candidates], d.centers, d.radii, d.sigmas, opts)
    return np.vstack([polished, x, paper])


def _chart_polish(x0: NDArray, c: NDArray, r: NDArray, s: NDArray, opts: EstimatorOptions
                  ) -> tuple[NDArray, NDArray[np.bool_]]:
    """Trust-region polish of points ``(m, 3)`` in a chart that straightens the thin valley.

    A sphere much more precise than the others confines the optimum to a thin curved shell
    around its centre; in Cartesian coordinates every step along the shell leaves it by a
    quadratic amount that the precise sphere's weight punishes, so LM crawls (at
    a sigma ratio of 1e5 it stopped at its cap 6.5 cm off).  Here the position is
    ``x = c_p + rho (e0 + a e1 + b e2) / |e0 + a e1 + b e2|`` about the centre ``c_p`` of the
    most precise sphere (a gnomonic chart centred on the start direction ``e0``), in which the
    precise sphere's residual ``(rho - r_p) / sigma_p`` is linear and the shell is flat;
    :func:`scipy.optimize.least_squares` (``"trf"``, ``x_scale="jac"``) minimises the whitened
    residuals.  The chart is re-centred when a solve leaves its middle.  Returns the points and
    whether each solve converged (a tolerance met, not the evaluation cap).
    """
    p = int(np.argmin(s))
    cp = c[p]
    out = np.array(x0, dtype=np.float64, copy=True).reshape(-1, 3)
    ok = np.zeros(len(out), dtype=bool)
    for k in range(len(out)):
        v = out[k] - cp
        rho = float(np.linalg.norm(v))
        if not np.isfinite(rho) or rho <= 0.0:
            continue
        for _ in range(opts.polish_recentre):
            e0 = v / np.linalg.norm(v)
            e1 = np.cross(e0, np.eye(3)[int(np.argmin(np.abs(e0)))])
            e1 /= np.linalg.norm(e1)
            basis = np.stack([e1, np.cross(e0, e1)])

            def point(q: NDArray, e0: NDArray = e0, basis: NDArray = basis) -> NDArray:
                w = e0 + q[:2] @ basis
                return cp + q[2] * w / np.linalg.norm(w)

            def fun(q: NDArray) -> NDArray:
                return (np.linalg.norm(point(q) - c, axis=1) - r) / s

            try:
                sol = least_squares(fun, np.array([0.0, 0.0, rho]), method="trf", x_scale="jac",
                                    xtol=POLISH_TOL, ftol=POLISH_TOL, gtol=POLISH_TOL,
                                    max_nfev=opts.polish_max_nfev)
            except (ValueError, np.linalg.LinAlgError):
                break
            if not np.all(np.isfinite(sol.x)):
                break
            xk = point(sol.x)
            if np.sum(fun(sol.x) ** 2) <= np.sum(fun(np.array([0.0, 0.0, rho])) ** 2):
                out[k] = xk
            ok[k] = sol.status > 0
            if np.max(np.abs(sol.x[:2])) < 0.5:
                break
            v, rho, ok[k] = out[k] - cp, float(np.linalg.norm(out[k] - cp)), False
    return out, ok


def _method_gradient(spheres: Sequence[GaussianSphere], d: _Data, region: Region | None,
                     rng: np.random.Generator | None, opts: EstimatorOptions) -> NDArray:
    # seeds "strategically located based on the spheres centres and intersection zones"
    seeds = np.vstack([d.frame.origin[None], _triple_points(d, opts.max_generation_spheres),
                       _random_seeds(d, rng, region, opts.random_seeds)])
    seeds = seeds[np.all(np.isfinite(seeds), axis=1)]
    return _gradient_ascent(seeds, d.centers, d.radii, d.sigmas, d.frame.spread, opts)


_Method = Callable[[Sequence[GaussianSphere], _Data, "Region | None", "np.random.Generator | None",
                    EstimatorOptions], NDArray]

_METHODS: dict[str, _Method] = {
    "ml": _method_ml,
    "paper": _method_paper,
    "srls": _method_srls,
    "gradient": _method_gradient,
}

#: Names accepted by :func:`estimate_position`.
POSITION_METHODS = tuple(_METHODS)


def _nan_estimate(method: str, status: str, message: str, t0: float) -> PositionEstimate:
    return PositionEstimate(np.full(3, np.nan), np.full((3, 3), np.inf), np.zeros((0, 3)), 0.0,
                            method, status, message, np.zeros(0), time.perf_counter() - t0)


def _distinct(points: NDArray, costs: NDArray, tol: float) -> tuple[NDArray, NDArray]:
    """Greedy de-duplication, lowest cost first (ties broken by coordinates)."""
    order = np.lexsort((points[:, 2], points[:, 1], points[:, 0], costs))
    pts = points[order]
    neighbours = cKDTree(pts).query_ball_point(pts, r=tol)  # O(k log k), not a (k, k) matrix
    suppressed = np.zeros(len(pts), dtype=bool)
    kept: list[int] = []
    for i in range(len(pts)):
        if not suppressed[i]:
            kept.append(i)
            suppressed[neighbours[i]] = True
    return pts[kept], costs[order][kept]


def estimate_position(
    spheres: Sequence[GaussianSphere],
    method: str = "ml",
    region: Region | None = None,
    rng: np.random.Generator | None = None,
    options: EstimatorOptions = ESTIMATOR_OPTIONS,
    certify: bool = False,
) -> PositionEstimate:
    """Estimate the robot position from Gaussian spheres.

    Parameters
    ----------
    spheres : sequence of GaussianSphere
        Centres (model landmarks), measured ranges and their standard deviations.
    method : {"ml", "paper", "srls", "gradient"}
        See the module docstring.
    region : Region, optional
        Valid positions (above the floor, inside the model).  Candidates inside it are
        preferred; it resolves the mirror ambiguity of coplanar landmarks.
    rng : numpy.random.Generator, optional
        Adds ``options.random_seeds`` uniformly drawn seeds ("ml", "gradient").  Without it
        the estimate is deterministic and uses only geometric seeds.
    options : EstimatorOptions
    certify : bool
        Fill ``PositionEstimate.certificate`` for the returned position with
        :func:`radialopt.certify_position` (default budgets); a NaN position gets an
        uncertified certificate.

    Returns
    -------
    PositionEstimate

    Raises
    ------
    RadialError
        - ``method`` is not one of :data:`POSITION_METHODS`.
        - Invalid spheres (e.g. :class:`~radialopt.errors.RadialError`).
    """
    if not isinstance(spheres, (Sequence, str, bytes, GaussianSphere, np.ndarray)) and isinstance(
            spheres, Iterable):
        spheres = list(spheres)  # a generator is read once; every method reads the spheres twice
    if not isinstance(method, str) or method not in _METHODS:
        raise RadialArgumentError(f"unknown position method {method!r:.100}; choose one of "
                                  f"{', '.join(POSITION_METHODS)}")
    if region is not None and not isinstance(region, Region):
        raise RadialArgumentError(f"region must be a radialopt Region or None, got {type(region).__name__}")
    if rng is not None and not isinstance(rng, np.random.Generator):
        raise RadialArgumentError(f"rng must be a numpy.random.Generator or None, got {type(rng).__name__} "
                                  f"({rng!r:.100})")
    instance("options", options, EstimatorOptions)
    if not isinstance(certify, (bool, np.bool_)):
        raise RadialArgumentError(f"certify must be a bool, got {certify!r:.100}")
    if certify:
        est = estimate_position(spheres, method, region, rng, options, certify=False)
        c, r, s = sphere_arrays(list(spheres), min_count=0, check_centers=False)
        if len(c) and np.all(np.isfinite(est.position)):
            cert = certify_arrays(c, r, s, est.position)
        else:
            cert = Certificate(False, "none", 0.0, float("inf"), 0.0, f"no position: {est.message}")
        return replace(est, certificate=cert, solve_time=est.solve_time + cert.solve_time)
    t0 = time.perf_counter()
    centers, radii, sigmas = sphere_arrays(spheres, min_count=0)
    spheres = list(spheres)
    n = len(centers)
    if n < 3:
        return _nan_estimate(method, "too_few_spheres",
                             f"a position needs at least 3 spheres, got {n}", t0)
    frame = _Frame.of(centers)
    rank = frame.rank(options.rank_tol)
    if rank < 2:
        return _nan_estimate(method, "degenerate_collinear",
                             f"the {n} sphere centres are collinear: the position is only known "
                             "up to a rotation about their line", t0)
    data = _Data(centers, radii, sigmas, frame, rank)
    try:
        with np.errstate(all="ignore"):
            raw = _METHODS[method](spheres, data, region, rng, options)
    except (np.linalg.LinAlgError, ZeroDivisionError, OverflowError, FloatingPointError) as exc:
        raise SolverError(f"estimate_position(method={method!r}): numerical failure with sigmas "
                          f"{sigmas.tolist()} ({type(exc).__name__}: {exc})") from exc
    raw = raw[np.all(np.isfinite(raw), axis=1)]
    if len(raw) == 0:
        return _nan_estimate(method, "degenerate_collinear",
                             "no finite candidate: the sphere centres are (nearly) degenerate", t0)
    coplanar = rank == 2
    if coplanar:  # the mirror image of every candidate is equally likely
        raw = np.vstack([raw, frame.mirror(raw)])
    costs = _costs(raw, centers, radii, sigmas)
    cand, cost = _distinct(raw, costs, options.distinct_tol * frame.spread)
    inside = (np.ones(len(cand), dtype=bool) if region is None
              else np.asarray(region.contains(cand, tol=options.region_tol)))
    order = np.lexsort((cost, ~inside))
    cand, cost, inside = cand[order], cost[order], inside[order]
    status, message = "ok", ""
    if method == "ml":  # the chosen point must be a converged minimum, not a capped iterate
        polished, conv = _chart_polish(cand[:1], centers, radii, sigmas, options)
        pc = _costs(polished, centers, radii, sigmas)[0]
        if pc < cost[0]:
            cand[0], cost[0] = polished[0], pc
        if not conv[0]:
            status = "not_converged"
            message = (f"the ML refinement stopped at its evaluation cap ({options.polish_max_nfev}) "
                       "without meeting its tolerances; the best point found is returned")
    if method == "gradient" and inside[0]:  # the same stopping rule as the ascent itself
        _, jac, _ = _residuals(cand[:1], centers, radii, sigmas)
        res = (np.linalg.norm(cand[0] - centers, axis=1) - radii) / sigmas
        step = np.linalg.norm(np.einsum("ni,n->i", jac[0], res)) / np.sum(1.0 / sigmas**2)
        if min(step, 0.1 * frame.spread) > options.gradient_step_tol * frame.spread * 10:
            status = "not_converged"
            message = (f"gradient ascent stopped at its cap ({options.gradient_max_iter} iterations) "
                       f"with a last step of {step:.3g} m; the best point found is returned")
    best = cand[0]
    density = np.exp(-0.5 * cost)
    try:
        cov = crlb(centers, sigmas, best, rcond=options.fisher_rcond)
    except SingularFisherError as exc:
        cov = np.full((3, 3), np.inf)
        status = "degenerate_coplanar" if coplanar else "degenerate"
        message = (f"{exc}; with coplanar centres and the position on their plane the height "
                   "above the plane is unobservable" if coplanar else str(exc))
    far = float(np.linalg.norm(best - frame.origin))
    if far > options.max_range_ratio * frame.spread and status in ("ok", "not_converged"):
        status = "degenerate"
        message = (f"the estimate lies {far:.3g} m from the centroid of landmarks spread over "
                   f"{frame.spread:.3g} m (more than max_range_ratio = {options.max_range_ratio:g} "
                   "spreads): the ranges do not fit the landmarks' scale")
    if status == "ok":
        status, message = _ambiguity(cand, cost, inside, region, coplanar, cov, frame, options)
    return PositionEstimate(best, cov, cand, float(density[0]), method, status, message, density,
                            time.perf_counter() - t0)


def _ambiguity(cand: NDArray, cost: NDArray, inside: NDArray, region: Region | None,
               coplanar: bool, cov: NDArray, frame: _Frame, opts: EstimatorOptions
               ) -> tuple[str, str]:
    if not inside[0]:
        return "outside_region", ("no candidate lies inside the region; the best one outside it "
                                  "is returned")
    if coplanar:
        mirror = frame.mirror(cand[:1])[0]
        sep = np.linalg.norm(cand - mirror, axis=1)
        twin = np.flatnonzero((sep <= opts.distinct_tol * frame.spread * 10) & inside)
        if twin.size and twin[0] != 0:
            return "ambiguous", ("the sphere centres are coplanar: the mirror image "
                                 f"{mirror.tolist()} across their plane is equally likely"
                                 + ("; the region does not resolve it" if region is not None else
                                    "; pass a region to resolve it"))
    std = float(np.sqrt(np.trace(cov)))
    dist = np.linalg.norm(cand - cand[0], axis=1)
    # density ratio exp(-(cost_k - cost_0) / 2), compared in log space (densities underflow)
    log_ratio = -0.5 * (cost - cost[0])
    rivals = np.flatnonzero((log_ratio >= np.log(opts.ambiguity_ratio)) & inside
                            & (dist > opts.ambiguity_sigmas * std))
    rivals = rivals[rivals != 0]
    if rivals.size:
        k = int(rivals[0])
        return "ambiguous", (f"candidate {cand[k].tolist()} has {np.exp(log_ratio[k]):.2f} of "
                             f"the best density and lies {dist[k]:.3g} m away "
                             f"({dist[k] / std:.1f} standard deviations)")
    return "ok", ""
