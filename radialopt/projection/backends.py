"""The methods behind :func:`~radialopt.projection.project_radii`: ``"active_set"`` (the
least-distance solvers), ``"cvxpy"`` (the DPP-compiled reference formulation and its exact
polish), ``"paper"`` (eq. 17 on the violated hyperplanes, within :data:`PAPER_MAX_FLATS` flats)
and ``"vertices"`` (the V-form projection); each maps a whitened instance to ``(z, status)``."""

from __future__ import annotations

import contextlib
import io
from collections.abc import Callable
from functools import lru_cache
from itertools import combinations
from math import comb

import numpy as np
from numpy.typing import NDArray

from .._ldp import _polish_certified, least_distance
from .._projection_types import _CVXPY_STATUS, _Problem
from ..errors import RadialArgumentError, SolverError
from ..spheres import Tolerances
from ..tolerances import (
    ACTIVE_SLACK,
    DUAL_FLOOR,
    KKT_RTOL,
    RANK_RTOL,
    SOLVER_OPTIONS,
    SUPPORT_DUAL_RTOL,
    SUPPORT_SLACK,
    TINY,
)

__all__ = ["METHODS", "PAPER_MAX_FLATS", "fresh_cvxpy_problem", "installed_cvxpy_solvers", "solver_options"]


# --------------------------------------------------------------------------- active set
def _solve_active_set(p: _Problem, solver: str | None, tol: Tolerances) -> tuple[NDArray, str]:
    return least_distance(p.G, p.h)


# --------------------------------------------------------------------------------- cvxpy
@lru_cache(maxsize=1)
def installed_cvxpy_solvers() -> tuple[str, ...]:
    """``cvxpy.installed_solvers()``, asked once (it costs milliseconds per call)."""
    import cvxpy as cp

    return tuple(cp.installed_solvers())


@lru_cache(maxsize=64)
def _cvxpy_problem(n: int, m: int):  # noqa: ANN202 - returns (problem, w, G, h)
    """The DPP-parametrised least-distance problem for n spheres, compiled on first solve."""
    import cvxpy as cp

    z = cp.Variable(n)
    G = cp.Parameter((m, n))
    h = cp.Parameter(m)
    prob = cp.Problem(cp.Minimize(cp.sum_squares(z)), [G @ z <= h])
    return prob, z, G, h


def fresh_cvxpy_problem(G: NDArray[np.float64], h: NDArray[np.float64]):  # noqa: ANN201
    """A freshly built (not cached) cvxpy problem for the same instance: the benchmark baseline."""
    import cvxpy as cp

    z = cp.Variable(G.shape[1])
    return cp.Problem(cp.Minimize(cp.sum_squares(z)), [G @ z <= h]), z


def solver_options(solver: str) -> dict:
    """Keyword options passed to cvxpy for ``solver`` (see :data:`SOLVER_OPTIONS`)."""
    return dict(SOLVER_OPTIONS.get(solver.upper(), {}))


def _scaled_instance(
    G: NDArray[np.float64], h: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """The least-distance problem rescaled for an interior-point solver.

    ``min |z|^2 s.t. G z <= h`` has rows of norm ``sigma_i`` (a spread of the sigma ratio) and
    an optimum ``|z|`` of up to ``1e5`` on grossly inconsistent ranges, so the solver's
    absolute tolerances (1e-10) meet relative ones of 1e-15 and it stops early.  Rows are
    normalised to unit length and ``z = s w`` with ``s`` the largest distance from the origin
    to a violated half-space (a lower bound on ``|z*|``), so that ``|w*|`` is of order one.
    Returns ``(G_hat, h_hat, s)``.
    """
    norms = np.linalg.norm(G, axis=1)
    norms = np.where(norms > 0, norms, 1.0)
    Gn = G / norms[:, None]
    hn = h / norms
    s = float(max(-hn.min(), 0.0)) or 1.0
    return Gn, hn / s, s


def _solve_cvxpy(p: _Problem, solver: str | None, tol: Tolerances) -> tuple[NDArray, str]:
    """Scaled solve (see ``_scaled_instance``), then an exact polish on the rows the solver
    reports active; the answer is called ``"optimal"`` only when the solver said so and the
    polish ended on an exact KKT point (multipliers >= 0, no violated row), else
    ``"optimal_inaccurate"`` (a solver's own ``optimal_inaccurate`` is never upgraded)."""
    import cvxpy as cp

    name = "CLARABEL" if solver is None else solver.upper()
    if name not in installed_cvxpy_solvers():
        raise RadialArgumentError(
            f"solver = {solver!r} is not an installed cvxpy solver; installed: "
            f"{', '.join(installed_cvxpy_solvers())}. Install e.g. `pip install osqp scs ecos`."
        )
    prob, w, G, h = _cvxpy_problem(*p.G.shape[::-1])
    Gs, hs, s = _scaled_instance(p.G, p.h)
    G.value = Gs
    h.value = hs
    try:
        if name == "OSQP":  # OSQP 1.x prints a line per solve even when not verbose (osqp#785)
            with contextlib.redirect_stdout(io.StringIO()):
                prob.solve(solver=name, **solver_options(name))
        else:
            prob.solve(solver=name, **solver_options(name))
    except cp.error.SolverError as exc:
        raise SolverError(f"cvxpy solver {name} failed: {exc}") from exc
    status = _CVXPY_STATUS.get(str(prob.status), "error")
    if status in ("error", "infeasible") or w.value is None:
        # The restriction polytope is never empty, so 'infeasible' is a solver failure too.
        raise SolverError(f"cvxpy solver {name} returned status {prob.status!r}; no answer")
    w_raw = np.asarray(w.value, dtype=np.float64)
    dual = prob.constraints[0].dual_value
    slack = hs - Gs @ w_raw
    if dual is not None:
        y = np.asarray(dual, dtype=np.float64)
        support = (y > SUPPORT_DUAL_RTOL * max(float(y.max()), DUAL_FLOOR)) | (slack <= SUPPORT_SLACK)
    else:
        support = slack <= ACTIVE_SLACK
    if hs.min() >= 0:  # the measured radii are feasible: the answer is exactly z = 0
        return np.zeros(p.G.shape[1]), status
    w_exact, certified = _polish_certified(Gs, hs, w_raw, support)
    if not certified:
        return s * w_raw, "optimal_inaccurate"
    return s * w_exact, status


# --------------------------------------------------------------------------------- paper
#: Most flats (intersections of k hyperplanes) the paper's rule projects onto before it gives
#: up with :class:`~radialopt.errors.RadialError` (D1: all C(84, k) flats of n = 8
#: took more than 30 s; the violated rows are few, so real instances stay far below this).
PAPER_MAX_FLATS = 100_000


def _solve_paper(p: _Problem, solver: str | None, tol: Tolerances) -> tuple[NDArray, str]:
    """Eq. 17 restricted to the violated hyperplanes (see :mod:`radialopt.projection`).

    Works in whitened coordinates ``z = H (r' - r)`` (the paper's ``Sd^n`` shifted to put the
    measured configuration at the origin), with unit rows.  Stage 1: flats of k = 1, 2, ...
    rows that the measured radii violate; the first k with a feasible projection wins (the
    closest of them).  Stage 2, only when no flat of violated rows is feasible: flats of any
    rows, the same way.  Feasibility is tested on the radii in metres (``A r' <= b + tol``).
    The answer is ``"optimal"`` when its KKT multipliers are >= 0 (it is then the exact
    optimum), ``"optimal_inaccurate"`` when it is feasible but not the minimum.
    """
    n = p.G.shape[1]
    ftol = tol.feasibility * p.scale  # metres
    if p.h.min() >= -ftol:
        return np.zeros(n), "optimal"
    norms = np.linalg.norm(p.G, axis=1)
    Gn, hn = p.G / norms[:, None], p.h / norms
    violated = np.flatnonzero(p.h < -ftol)
    budget = [PAPER_MAX_FLATS]
    for rows in (violated, np.arange(len(hn))):
        for k in range(1, min(n, len(rows)) + 1):
            count = comb(len(rows), k)
            if count > budget[0]:
                raise RadialArgumentError(
                    f"method 'paper' with n = {n} spheres: {len(violated)} of {len(hn)} rows are "
                    f"violated and no flat of fewer than {k} rows is feasible; the next stage has "
                    f"{count} flats, beyond the budget PAPER_MAX_FLATS = {PAPER_MAX_FLATS}. Use "
                    "method='active_set' (the exact optimum)")
            budget[0] -= count
            found = _closest_feasible_on_flats(p, Gn, hn, rows, k, ftol)
            if found is not None:
                return found
    raise SolverError(f"method 'paper' found no feasible projection on any flat (n = {n})")


def _closest_feasible_on_flats(
    p: _Problem, Gn: NDArray, hn: NDArray, rows: NDArray, k: int, ftol: float, chunk: int = 20000
) -> tuple[NDArray, str] | None:
    """Project ``z = 0`` onto every flat of k of ``rows`` (``Gn_T z = hn_T``) and return the
    closest feasible point with its status, or None when no flat gives a feasible point."""
    best, best_d, best_ok = None, np.inf, False
    subsets_iter = combinations(rows.tolist(), k)
    while True:
        block = np.array([s for _, s in zip(range(chunk), subsets_iter, strict=False)], dtype=np.int64)
        if block.size == 0:
            break
        block = block.reshape(-1, k)
        As = Gn[block]  # (N, k, n)
        gram = np.einsum("skn,sjn->skj", As, As)
        ok = np.abs(np.linalg.det(gram)) > RANK_RTOL
        if np.any(ok):
            y = np.linalg.solve(gram[ok], hn[block[ok]][..., None])[..., 0]  # (N', k)
            pts = np.einsum("skn,sk->sn", As[ok], y)
            feasible = np.all(pts @ p.G.T - p.h <= ftol, axis=1)
            if np.any(feasible):
                d = np.linalg.norm(pts[feasible], axis=1)
                i = int(np.argmin(d))
                if d[i] < best_d:
                    best, best_d = pts[feasible][i], d[i]
                    # KKT: z = -Gn_T^T lam with lam = -y >= 0 (to rounding)
                    ymax = float(np.max(y[feasible][i]))
                    best_ok = ymax <= KKT_RTOL * max(float(np.abs(y[feasible][i]).max()), TINY)
        if block.shape[0] < chunk:
            break
    if best is None:
        return None
    return best, "optimal" if best_ok else "optimal_inaccurate"


# ------------------------------------------------------------------------------ vertices
def _solve_vertices(p: _Problem, solver: str | None, tol: Tolerances) -> tuple[NDArray, str]:
    from ..vertices import enumerate_vertices, project_vform

    enum = enumerate_vertices(p.polytope)
    point, _ = project_vform(enum, p.radii, p.sigmas)
    return (point - p.radii) / p.sigmas, "optimal"


_BACKENDS: dict[str, Callable[[_Problem, str | None, Tolerances], tuple[NDArray, str]]] = {
    "active_set": _solve_active_set,
    "cvxpy": _solve_cvxpy,
    "vertices": _solve_vertices,
    "paper": _solve_paper,
}

METHODS = tuple(_BACKENDS)
