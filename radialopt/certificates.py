"""Certificates of global optimality for the range-only ML position.

The ML position minimises the cost of :func:`radialopt.estimate_position` (``method="ml"``)::

    f(x) = sum_i (|x - c_i| - r_i)^2 / s_i^2 ,   x in R^3,

with ``w_i = 1 / s_i^2`` below.  :func:`certify_position` proves (or fails to prove) that a
given ``x_hat`` is a global minimiser of ``f`` up to a gap ``tol = max(abs_gap, rel_gap f(x_hat))``:
``certified=True`` means ``f(x_hat) - lower_bound <= tol`` where ``lower_bound`` is a proven
lower bound of ``min f``.  Two proofs are tried.

Closed form (the Shor relaxation is tight)
    For ``t > 0`` and ``r >= 0``, ``2 r d <= r (d^2 / t + t)`` (AM-GM), so with ``d_i = |x - c_i|``
    and ``t_i = d_hat_i = |x_hat - c_i| > 0``::

        f(x) >= q(x) = sum_i w_i [(1 - r_i / d_hat_i) |x - c_i|^2 - r_i d_hat_i + r_i^2],

    with equality at ``x_hat``.  ``q`` is a quadratic with Hessian ``2 lambda_bar I``,
    ``lambda_bar = sum_i w_i (d_hat_i - r_i) / d_hat_i``, and its gradient at ``x_hat`` is
    ``g = sum_i 2 w_i (d_hat_i - r_i) u_i = grad f(x_hat)``.  Hence, when ``lambda_bar > 0``::

        min f >= min q = f(x_hat) - |g|^2 / (4 lambda_bar),

    a bound that needs no exact stationarity: at a stationary point (``g = 0``) with
    ``lambda_bar >= 0`` it proves ``x_hat`` globally optimal; a point far from stationary gets
    a large gap and no closed-form certificate.

Spatial branch and bound (when the closed form does not close the gap)
    *Start box.*  A global minimiser ``x*`` has ``f(x*) <= f(x_hat)`` and
    ``f(x*) >= w_k (|x* - c_k| - r_k)^2`` for every k, so ``|x* - c_k| <= r_k + s_k sqrt(f(x_hat))``:
    the intersection of those balls' bounding boxes contains every global minimiser.

    *Interval bound on a box B.*  ``d_i`` ranges over ``[dmin_i, dmax_i]`` on B (exact: the
    distance from ``c_i`` to the clamped point, and to the farthest corner), so the term is at
    least ``w_i max(0, dmin_i - r_i, r_i - dmax_i)^2``; the bound is their sum.

    *Centred second-order bound.*  The Hessian of term i is ``2 w_i [(1 - r_i/d) I + (r_i/d) u u^T]``
    with eigenvalues ``2 w_i`` and ``2 w_i (1 - r_i/d)``, so on B every eigenvalue of the Hessian
    is at least ``lam = sum_i 2 w_i min(1, 1 - r_i / dmin_i)``, and with m the centre of B
    ``f(x) >= f(m) + g(m).(x - m) + lam/2 |x - m|^2``, minimised over B exactly (separable when
    ``lam > 0``; a corner bound when ``lam <= 0``).  The box bound is the larger of the two.

    *Convex ball around x_hat.*  With ``H(x)`` the Hessian, ``rho = r/d`` and
    ``|x - x_hat| <= delta < min d_hat_i``, ``|H(x) - H(x_hat)|_2 <= sum_i 2 w_i r_i
    [delta / (d_hat_i (d_hat_i - delta)) + delta / d_hat_i^2]`` (``|rho - rho_hat| <= r delta /
    (d_hat (d_hat - delta))`` and ``|u u^T - u_hat u_hat^T|_2 = sin(angle) <= delta / d_hat``).  The
    largest delta with this below ``lambda_min(H(x_hat)) / 2`` gives a ball on which f is
    ``mu``-strongly convex, ``mu >= lambda_min(H(x_hat)) / 2``, so on it ``f >= f(x_hat) -
    min(|g|^2 / (2 mu), |g| delta)``.  Boxes inside the ball are closed with that bound.

    Boxes whose bound is at least ``f(x_hat) - tol`` are pruned; the rest are split along their
    widest side, the lowest bounds first, in vectorised batches.  A box centre cheaper than
    ``f(x_hat) - tol`` disproves the optimality at once.  Every bound is lowered by a rounding
    margin before it is compared.  ``certified=True`` when no box remains; ``False`` when the
    time or node budget runs out (``lower_bound`` is then the smallest bound of the leaves, still
    a proven bound because the leaves cover the start box).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._checks import integer, point3, real_scalar
from .spheres import GaussianSphere, sphere_arrays
from .tolerances import CERTIFICATE_GAP, CERTIFICATE_ROUNDING, HESSIAN_ROUNDING, TINY

__all__ = [
    "CERTIFICATE_METHODS",
    "Certificate",
    "CertificateMethod",
    "certify_position",
    "closed_form_multiplier",
]

#: Values of :attr:`Certificate.method`: the proof that certified, ``"none"`` without one.
CertificateMethod = Literal["closed_form", "branch_and_bound", "sdp", "none"]
CERTIFICATE_METHODS: tuple[str, ...] = get_args(CertificateMethod)


@dataclass(frozen=True)
class Certificate:
    """A proof (or a failed attempt) of global optimality of a position.

    Attributes
    ----------
    certified : bool
        True only with a proof that ``f(position) - min f <= gap``, gap within the tolerance.
    method : {"closed_form", "branch_and_bound", "sdp", "none"}
        The proof that certified; ``"none"`` when not certified.
    lower_bound : float
        A proven lower bound of the global minimum cost (0 is always one).
    gap : float
        ``f(position) - lower_bound`` (>= 0).
    solve_time : float
        Seconds.
    message : str
        What was proven, or why not.
    """

    certified: bool
    method: CertificateMethod
    lower_bound: float
    gap: float
    solve_time: float
    message: str = ""


def _cost_grad(x: NDArray, c: NDArray, r: NDArray, w: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Costs ``(m,)``, gradients ``(m, 3)`` and distances ``(m, n)`` at points ``(m, 3)``."""
    diff = x[:, None, :] - c[None]
    d = np.sqrt(np.einsum("mnk,mnk->mn", diff, diff))
    res = d - r
    cost = np.einsum("mn,mn->m", res * res, np.broadcast_to(w, res.shape))
    coef = 2.0 * w * res / np.where(d > 0, d, np.inf)
    grad = np.einsum("mn,mnk->mk", coef, diff)
    return cost, grad, d


def closed_form_multiplier(centers: NDArray, radii: NDArray, sigmas: NDArray, position: NDArray
                           ) -> float:
    """``lambda_bar = sum_i (d_i - r_i) / (s_i^2 d_i)`` at ``position`` (NaN on a centre)."""
    d = np.linalg.norm(position - centers, axis=1)
    if np.any(d <= 0):
        return float("nan")
    return float(np.sum((d - radii) / (sigmas**2 * d)))


def _closed_form(c: NDArray, r: NDArray, w: NDArray, x: NDArray, f_hat: float, g: NDArray,
                 d_hat: NDArray) -> tuple[float, str]:
    """Lower bound from the tight Shor relaxation (``-inf`` when it gives none)."""
    if np.any(d_hat <= 0):
        return -np.inf, "position on a sphere centre: no closed-form bound"
    lam = float(np.sum(w * (d_hat - r) / d_hat))
    if lam <= 0:
        if lam == 0 and not np.any(g):
            return f_hat, "lambda_bar = 0 at a stationary point"
        return -np.inf, f"lambda_bar = {lam:.3g} < 0: the relaxation is not tight here"
    return f_hat - float(g @ g) / (4.0 * lam), f"lambda_bar = {lam:.3g} >= 0"


def _convex_ball(c: NDArray, r: NDArray, w: NDArray, x: NDArray, d_hat: NDArray
                 ) -> tuple[float, float]:
    """Radius ``delta`` and modulus ``mu`` of a ball around ``x`` where f is mu-strongly convex
    (``(0, 0)`` when none is found)."""
    if np.any(d_hat <= 0):
        return 0.0, 0.0
    u = (x - c) / d_hat[:, None]
    rho = r / d_hat
    H = 2.0 * (np.sum(w * (1.0 - rho)) * np.eye(3) + np.einsum("n,ni,nj->ij", w * rho, u, u))
    lam0 = float(np.linalg.eigvalsh(H)[0]) - HESSIAN_ROUNDING * float(np.abs(H).sum())
    if lam0 <= 0:
        return 0.0, 0.0
    deltas = d_hat.min() * 0.5 ** np.arange(1, 60)
    dd = deltas[:, None]
    pert = np.sum(2.0 * w * r * (dd / (d_hat * (d_hat - dd)) + dd / d_hat**2), axis=1)
    ok = np.flatnonzero(pert <= 0.5 * lam0)
    if ok.size == 0:
        return 0.0, 0.0
    k = ok[0]
    return float(deltas[k]), float(lam0 - pert[k])


def _box_bounds(lo: NDArray, hi: NDArray, c: NDArray, r: NDArray, w: NDArray
                ) -> tuple[NDArray, NDArray]:
    """Lower bounds of f on boxes ``(m, 3)`` and the costs at their centres."""
    near = np.clip(c[None], lo[:, None, :], hi[:, None, :]) - c[None]
    dmin = np.sqrt(np.einsum("mnk,mnk->mn", near, near))
    far = np.maximum(np.abs(lo[:, None, :] - c[None]), np.abs(hi[:, None, :] - c[None]))
    dmax = np.sqrt(np.einsum("mnk,mnk->mn", far, far))
    gap = np.maximum(np.maximum(dmin - r, r - dmax), 0.0)
    lb1 = gap**2 @ w
    # centred second-order form
    m = 0.5 * (lo + hi)
    half = 0.5 * (hi - lo)
    fm, gm, _ = _cost_grad(m, c, r, w)
    with np.errstate(divide="ignore", invalid="ignore"):
        curv = np.where(dmin > 0, np.minimum(1.0, 1.0 - r / np.where(dmin > 0, dmin, 1.0)), -np.inf)
    lam = 2.0 * (curv @ w) if np.all(np.isfinite(curv)) else 2.0 * np.sum(curv * w, axis=1)
    pos = lam > 0
    lb2 = np.full(len(lo), -np.inf)
    if np.any(pos):
        lp = lam[pos][:, None]
        t = np.clip(-gm[pos] / lp, -half[pos], half[pos])
        lb2[pos] = fm[pos] + np.sum(gm[pos] * t + 0.5 * lp * t * t, axis=1)
    neg = ~pos & np.isfinite(lam)
    if np.any(neg):
        lb2[neg] = (fm[neg] - np.sum(np.abs(gm[neg]) * half[neg], axis=1)
                    + 0.5 * lam[neg] * np.sum(half[neg] ** 2, axis=1))
    lb = np.maximum(lb1, lb2)
    lb = lb - CERTIFICATE_ROUNDING * (np.abs(lb) + fm) - TINY
    return np.maximum(lb, 0.0), fm


def _branch_and_bound(c: NDArray, r: NDArray, s: NDArray, w: NDArray, x: NDArray, f_hat: float,
                      g: NDArray, d_hat: NDArray, tol: float, deadline: float, max_nodes: int,
                      batch: int) -> tuple[bool, float, int, str]:
    """Returns ``(certified, lower_bound, nodes, message)``."""
    reach = r + s * np.sqrt(f_hat)
    lo0 = np.max(c - reach[:, None], axis=0)
    hi0 = np.min(c + reach[:, None], axis=0)
    if np.any(lo0 > hi0):  # impossible unless f_hat was mis-evaluated; the box must hold x
        lo0, hi0 = np.minimum(lo0, x), np.maximum(hi0, x)
    threshold = f_hat - tol
    delta, mu = _convex_ball(c, r, w, x, d_hat)
    gn = float(np.linalg.norm(g))
    ball_lb = -np.inf
    if delta > 0:
        ball_lb = f_hat - min(gn * gn / (2.0 * mu), gn * delta)
        ball_lb -= CERTIFICATE_ROUNDING * abs(f_hat) + TINY
        if ball_lb < threshold:
            delta = 0.0  # x_hat is too far from stationary for the ball to close
    lo, hi = lo0[None].copy(), hi0[None].copy()
    lbs, fm = _box_bounds(lo, hi, c, r, w)
    closed_min = np.inf  # smallest bound among closed leaves
    nodes = 1
    better: NDArray | None = None

    def settle(lo, hi, lbs, fm):
        nonlocal closed_min, better
        if better is None:
            cheaper = np.flatnonzero(fm < threshold)
            if cheaper.size:
                k = cheaper[np.argmin(fm[cheaper])]
                better = 0.5 * (lo[k] + hi[k])
        if delta > 0:
            corner = np.maximum(np.abs(lo - x), np.abs(hi - x))
            inside = np.einsum("mk,mk->m", corner, corner) <= delta * delta
            lbs = np.where(inside, np.maximum(lbs, ball_lb), lbs)
        done = lbs >= threshold
        if np.any(done):
            closed_min = min(closed_min, float(lbs[done].min()))
        keep = ~done
        return lo[keep], hi[keep], lbs[keep]

    lo, hi, lbs = settle(lo, hi, lbs, fm)
    while len(lo):
        if better is not None:
            lb = min(closed_min, float(lbs.min()))
            return False, lb, nodes, (f"not globally optimal: the cost at {better.tolist()} is below "
                                      f"f(position) - {tol:.3g}")
        if nodes >= max_nodes or time.perf_counter() > deadline:
            lb = min(closed_min, float(lbs.min()))
            why = "node" if nodes >= max_nodes else "time"
            return False, lb, nodes, (f"{why} budget exhausted after {nodes} boxes with {len(lo)} "
                                      f"open (smallest bound {lb:.6g}, f(position) {f_hat:.6g})")
        if len(lo) > batch:
            pick = np.argpartition(lbs, batch)[:batch]
            rest = np.ones(len(lo), dtype=bool)
            rest[pick] = False
            plo, phi = lo[pick], hi[pick]
            lo, hi, lbs = lo[rest], hi[rest], lbs[rest]
        else:
            plo, phi = lo, hi
            lo, hi, lbs = lo[:0], hi[:0], lbs[:0]
        axis = np.argmax(phi - plo, axis=1)
        rows = np.arange(len(plo))
        mid = 0.5 * (plo[rows, axis] + phi[rows, axis])
        hi_a, lo_b = phi.copy(), plo.copy()
        hi_a[rows, axis] = mid
        lo_b[rows, axis] = mid
        clo, chi = np.vstack([plo, lo_b]), np.vstack([hi_a, phi])
        nodes += len(clo)
        clb, cfm = _box_bounds(clo, chi, c, r, w)
        clo, chi, clb = settle(clo, chi, clb, cfm)
        lo, hi, lbs = np.vstack([lo, clo]), np.vstack([hi, chi]), np.concatenate([lbs, clb])
    if better is not None:
        return False, min(closed_min, f_hat), nodes, (
            f"not globally optimal: the cost at {better.tolist()} is below f(position) - {tol:.3g}")
    lb = min(closed_min, f_hat)
    extra = f" (convex ball of radius {delta:.3g} around the position)" if delta > 0 else ""
    return True, lb, nodes, f"every box of the search closed after {nodes} boxes{extra}"


def _check_params(budget_s: float, max_nodes: int, rel_gap: float, abs_gap: float, batch: int
                  ) -> tuple[float, int, float, float, int]:
    return (real_scalar("budget_s", budget_s, minimum=0.0, maximum=3600.0),
            integer("max_nodes", max_nodes, minimum=1, maximum=10**8),
            real_scalar("rel_gap", rel_gap, minimum=0.0, maximum=1.0),
            real_scalar("abs_gap", abs_gap, minimum=0.0, maximum=1e300),
            integer("batch", batch, minimum=1, maximum=10**6))


def certify_arrays(centers: NDArray, radii: NDArray, sigmas: NDArray, position: NDArray, *,
                   budget_s: float = 0.5, max_nodes: int = 200_000, rel_gap: float = CERTIFICATE_GAP,
                   abs_gap: float = CERTIFICATE_GAP, batch: int = 256) -> Certificate:
    """:func:`certify_position` on arrays already validated (``(n, 3)``, ``(n,)``, ``(n,)``, ``(3,)``)."""
    t0 = time.perf_counter()
    c, r, s, x = centers, radii, sigmas, position
    w = 1.0 / s**2
    f_arr, g_arr, d_arr = _cost_grad(x[None], c, r, w)
    f_hat, g, d_hat = float(f_arr[0]), g_arr[0], d_arr[0]
    tol = max(abs_gap, rel_gap * f_hat)

    def done(cert: bool, method, lb: float, msg: str) -> Certificate:
        lb = min(max(lb, 0.0), f_hat)
        return Certificate(cert, method if cert else "none", lb, f_hat - lb,
                           time.perf_counter() - t0, msg)

    if f_hat <= tol:
        return done(True, "closed_form", 0.0, f"f(position) = {f_hat:.3g} <= tolerance; f >= 0")
    lb_cf, msg_cf = _closed_form(c, r, w, x, f_hat, g, d_hat)
    lb_cf -= CERTIFICATE_ROUNDING * f_hat
    if f_hat - lb_cf <= tol:
        return done(True, "closed_form", lb_cf, f"{msg_cf}: the Shor relaxation is tight, "
                    f"gap {f_hat - lb_cf:.3g} <= {tol:.3g}")
    if len(c) == 0:
        return done(False, "none", 0.0, "no spheres")
    ok, lb_bb, nodes, msg_bb = _branch_and_bound(c, r, s, w, x, f_hat, g, d_hat, tol,
                                                 t0 + budget_s, max_nodes, batch)
    if ok:
        return done(True, "branch_and_bound", lb_bb, f"{msg_cf}; branch and bound: {msg_bb}")
    return done(False, "none", max(lb_cf, lb_bb, 0.0), f"{msg_cf}; branch and bound: {msg_bb}")


def certify_position(spheres: Sequence[GaussianSphere], position: ArrayLike, *,
                     budget_s: float = 0.5, max_nodes: int = 200_000, rel_gap: float = CERTIFICATE_GAP,
                     abs_gap: float = CERTIFICATE_GAP, batch: int = 256) -> Certificate:
    """Prove that ``position`` minimises the ML range cost globally (see the module docstring).

    Parameters
    ----------
    spheres : sequence of GaussianSphere
        Centres, measured ranges and their standard deviations (at least one).
    position : (3,) float
        The candidate, e.g. ``estimate_position(spheres).position``.
    budget_s : float
        Time budget of the branch and bound, seconds.
    max_nodes : int
        Node (box) budget of the branch and bound.
    rel_gap, abs_gap : float
        Certified when ``f(position) - lower_bound <= max(abs_gap, rel_gap f(position))``
        (the cost is a chi-square: ``abs_gap = 1e-6`` is a density ratio of ``exp(-5e-7)``).
    batch : int
        Boxes split per vectorised step.

    Returns
    -------
    Certificate

    Raises
    ------
    RadialError
        - ``spheres`` holds something else than GaussianSphere, or ``position`` is not ``(3,)``.
        - ``position`` is not finite.
        - A budget or tolerance out of range, fewer than one sphere, coincident centres.
    """
    c, r, s = sphere_arrays(spheres, min_count=1)
    x = point3("position", position)
    budget_s, max_nodes, rel_gap, abs_gap, batch = _check_params(budget_s, max_nodes, rel_gap, abs_gap,
                                                                 batch)
    return certify_arrays(c, r, s, x, budget_s=budget_s, max_nodes=max_nodes, rel_gap=rel_gap,
                          abs_gap=abs_gap, batch=batch)
