"""The normalised radial projection (paper section 4.4, docs/design.md#m4, #m5, #m6).

Given measured radii ``r`` (ranges of the percepts) that do not make every pair of spheres
meet, find the adjusted radii ``r'`` in the restriction polytope ``A r' <= b`` that lose the
least density, i.e. minimise ``|H (r' - r)|^2`` with ``H = diag(1/sigma)`` (eqs. 16-19).
All methods solve it in whitened variables ``z = H (r' - r)``::

    minimise |z|^2  subject to  (A H^-1) z <= b - A r

which is a least-distance problem.  Four methods, one entry point :func:`project_radii`:

``"active_set"`` (default, the fast path)
    Up to ``SMALL_CORE_SPHERES`` spheres: Goldfarb and Idnani's dual active-set method on
    the two-nonzero rows of the pairs, in plain Python (numpy's per-call cost dominates arrays
    this small), ending on a certified KKT point (``_ldp_pairs``).  Beyond that, or when
    that loop does not certify: Lawson and Hanson's least-distance programming, a non-negative
    least squares problem (Solving Least Squares Problems, 1974, ch. 23) solved by
    :func:`scipy.optimize.nnls` in compiled code, then polished by an exact equality-
    constrained solve on the active rows and a KKT check.  Both give the unique optimum.
``"cvxpy"``
    The reference formulation of the design card, compiled once per (sphere count, solver)
    with DPP parameters and re-used; Clarabel with tight tolerances by default, any installed
    cvxpy solver by name.
``"vertices"``
    Explicit vertex enumeration of the polyhedron and the projection solved in V-form
    (:mod:`radialopt.vertices`).
``"paper"``
    Eq. 17 restricted to the VIOLATED hyperplanes: project the measured configuration
    perpendicularly onto each hyperplane of ``Sd^n`` that it violates and keep the closest
    projection that satisfies every row (eq. 16); when none is feasible, continue to ridges
    (flats of 2, 3, ... violated hyperplanes), as the paper's words "the closest point ... on
    the cells or ridges" suggest; only when no flat of violated rows is feasible does it try
    flats of any rows.  Why violated rows only: the optimum lies on a face of violated rows
    in practice, while projecting onto a hyperplane the radii already satisfy can land on a
    feasible but far point (issue 12, D2: centres (4,3,0), (2,1,0), (2,3,2), radii (2,5,5),
    sigma 1 gave cost 25.7 against the optimum 0.0196).  A feasible single violated-
    hyperplane projection is provably optimal (its distance is a lower bound on every
    feasible point's); on a ridge the rule can lose, and then reports
    ``"optimal_inaccurate"``: the status is ``"optimal"`` only when the answer's KKT
    multipliers are >= 0, i.e. it IS the optimum.  The work is bounded by
    :data:`PAPER_MAX_FLATS` flats (D1); beyond it :class:`~radialopt.errors.RadialError`.

Every method's answer is checked against ``A r' <= b`` in metres: a violation above
``tol.feasibility * scale`` turns ``"optimal"`` into ``"optimal_inaccurate"``, one above
``tol.agreement * scale`` raises :class:`~radialopt.errors.SolverError` (``scale`` = the
largest of the centre distances, the radii and 1 m).

:func:`project_radii` takes spheres or, by keyword, arrays (``centers=, radii=, sigmas=``) and
checks its input (:func:`~radialopt.spheres.sphere_arrays`, :func:`~radialopt.spheres.checked_arrays`);
internal callers whose data were checked where they were made (worldgraph's ``localize``, the
range-only estimators) call ``project_radii_unchecked`` with arrays: the same computation
and answer without the checks.  :func:`project_radii_batch` solves many instances of the same
sphere count at once: the small-instance dual active set vectorised across the instances
(``_batch_dual_active_set``), tested against the loop of single solves
(``_project_radii_batch_reference``).

``check=True`` verifies any method's answer against the vertex enumeration (V-form optimality
certificate and the V-form optimum) and raises :class:`~radialopt.errors.VerificationError`
on disagreement; ``check="exact"`` does the same in exact rational arithmetic with pycddlib's
GMP mode (:func:`verify_solution_exact`).

The cvxpy path rescales the whitened problem for the solver (unit rows, ``z`` in units of the
largest violation), then polishes the answer exactly on the rows the solver reports active;
it reports ``"optimal"`` only when the polish ends on an exact KKT point and the solver said
``optimal``, otherwise ``"optimal_inaccurate"``.

The least-distance solvers live in ``radialopt._ldp`` (the NNLS route and its polish) and
``radialopt._dual_active_set`` (the small-instance core), the rational arithmetic of
``check="exact"`` in ``radialopt._exact_check``; this module imports them.
"""

from __future__ import annotations

import contextlib
import io
import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from functools import cached_property, lru_cache
from itertools import combinations
from math import comb
from typing import Literal, get_args

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._checks import MAX_SIGMA, MIN_SIGMA_RELATIVE, instance, real_array, sigma_range
from ._dual_active_set import SMALL_CORE_SPHERES as SMALL_CORE_SPHERES
from ._dual_active_set import _dot, _ldp_pairs, _pair_setup
from ._exact_check import _cdd_gmp, _exact_generators, _exact_kkt_point
from ._ldp import CONSTRAINT_GENERATION_ROWS as CONSTRAINT_GENERATION_ROWS
from ._ldp import _polish_certified
from ._ldp import least_distance as least_distance
from .errors import (
    RadialError,
    SolverError,
    VerificationError,
)
from .polytope import RestrictionPolytope, pair_pattern
from .spheres import (
    TOLERANCES,
    GaussianSphere,
    Tolerances,
    check_distinct_centers,
    checked_arrays,
    sphere_arrays,
)
from .tolerances import (
    ACTIVE_SLACK,
    DUAL_FLOOR,
    KKT_RTOL,
    RADIUS_ROUNDING,
    RANK_RTOL,
    SUPPORT_DUAL_RTOL,
    SUPPORT_SLACK,
    TINY,
)
from .tolerances import CLARABEL_TIGHT as CLARABEL_TIGHT  # re-exported: radialopt.projection.CLARABEL_TIGHT
from .tolerances import FARKAS_LAST_ZERO as FARKAS_LAST_ZERO  # re-exported (._ldp uses them)
from .tolerances import FARKAS_ZERO as FARKAS_ZERO
from .tolerances import ROUNDING_RTOL as ROUNDING_RTOL
from .tolerances import SOLVER_OPTIONS as SOLVER_OPTIONS

__all__ = [
    "BATCH_CHUNK",
    "BatchSolution",
    "CLARABEL_TIGHT",
    "CONSTRAINT_GENERATION_ROWS",
    "FARKAS_LAST_ZERO",
    "FARKAS_ZERO",
    "METHODS",
    "PAPER_MAX_FLATS",
    "ROUNDING_RTOL",
    "RadialSolution",
    "RadialStatus",
    "SMALL_CORE_SPHERES",
    "SOLVER_OPTIONS",
    "STATUSES",
    "fresh_cvxpy_problem",
    "installed_cvxpy_solvers",
    "least_distance",
    "project_radii",
    "project_radii_batch",
    "solver_options",
    "verify_solution",
    "verify_solution_exact",
]

#: The shared status set every backend maps its native status onto.
RadialStatus = Literal["optimal", "optimal_inaccurate", "infeasible", "error"]
STATUSES: tuple[str, ...] = get_args(RadialStatus)


@dataclass(frozen=True)
class RadialSolution:
    """Result of :func:`project_radii` (one dataclass for every backend).

    Attributes
    ----------
    radii : (n,) float
        Adjusted radii r' (metres), in the restriction polytope.
    displacement : (n,) float
        ``r' - r`` (metres): how much each sphere was dilated (+) or contracted (-).
    density : float
        ``exp(-1/2 |H (r' - r)|^2)`` in (0, 1]: the density kept (eq. 18-20); 1 when the
        measured configuration was already valid.
    status : str
        One of :data:`STATUSES`.
    method : str
        ``"active_set"``, ``"cvxpy"``, ``"vertices"`` or ``"paper"``.
    solver : str or None
        The cvxpy solver name for ``method="cvxpy"``, else None.
    solve_time : float
        Wall time of the solve, seconds.
    active_rows : tuple of int
        Rows of the polytope's ``A`` that are tight at the answer.
    normalized_displacement : float
        ``|H (r' - r)|``, the length of the optimal offset V_opt in ``Sd^n``;
        ``density = exp(-normalized_displacement**2 / 2)`` (which underflows to 0 beyond ~38).
    """

    radii: NDArray[np.float64]
    displacement: NDArray[np.float64]
    density: float
    status: str
    method: str
    solver: str | None
    solve_time: float
    active_rows: tuple[int, ...] = field(default=())
    normalized_displacement: float = 0.0


@dataclass(frozen=True)
class _Problem:
    """A projection instance in whitened form: min |z|^2 s.t. G z <= h, G = A diag(sigma)."""

    centers: NDArray[np.float64]
    radii: NDArray[np.float64]
    sigmas: NDArray[np.float64]
    G: NDArray[np.float64]
    h: NDArray[np.float64]
    b: NDArray[np.float64]
    scale: float

    @classmethod
    def build(cls, spheres: Sequence[GaussianSphere], tol: Tolerances) -> _Problem:
        centers, radii, sigmas = sphere_arrays(spheres, min_count=2, tol=tol, check_centers=False)
        return cls.from_arrays(centers, radii, sigmas, tol)

    @classmethod
    def from_arrays(cls, centers: NDArray[np.float64], radii: NDArray[np.float64],
                    sigmas: NDArray[np.float64], tol: Tolerances) -> _Problem:
        """The instance of checked arrays (only coincident centres are tested here)."""
        iu, ju, A, b_sign = pair_pattern(len(radii))
        d = np.sqrt(np.sum((centers[iu] - centers[ju]) ** 2, axis=1))
        if np.any(d <= tol.coincident):
            check_distinct_centers(centers, tol)  # raises, naming the pair
        b = b_sign * np.repeat(d, 3)
        scale = max(float(d.max()), float(radii.max()), 1.0)  # typical length, for tolerances
        return cls(centers, radii, sigmas, A * sigmas, b - A @ radii, b, scale)

    def checked_status(self, z: NDArray[np.float64], status: str, method: str, tol: Tolerances) -> str:
        """The status an answer ``z`` may claim: its radii must satisfy ``A r <= b`` in metres.

        The stated tolerance is ``tol.feasibility * L + 1e-15 * max(r)`` with ``L`` the largest
        of the centre distances, the adjusted radii and 1 m (the second term is the rounding of
        ``r' = r + sigma z`` from measured radii ``r``).  A larger violation turns
        ``"optimal"`` into ``"optimal_inaccurate"``; one above ``tol.agreement * L + 1e-15 *
        max(r)`` (or a non-finite answer) raises :class:`SolverError`.
        """
        radii = self.radii + self.sigmas * z
        if not np.all(np.isfinite(radii)):
            raise SolverError(f"method {method!r}: non-finite radii {radii.tolist()}")
        A = pair_pattern(len(radii))[2]
        violation = float(np.max(A @ radii - self.b))
        L = max(float(np.max(self.b)) * np.sqrt(2.0), float(np.abs(radii).max()), 1.0)
        rounding = RADIUS_ROUNDING * float(np.abs(self.radii).max())
        return _status_of(violation, L, rounding, status, method, tol)

    @cached_property
    def polytope(self) -> RestrictionPolytope:
        return RestrictionPolytope.from_centers(self.centers, self.sigmas)

    def solution(
        self, z: NDArray[np.float64], status: str, method: str, solver: str | None, t0: float
    ) -> RadialSolution:
        radii = self.radii + self.sigmas * z
        slack = self.h - self.G @ z
        active = tuple(np.flatnonzero(np.abs(slack) <= ACTIVE_SLACK * self.scale).tolist())
        return RadialSolution(
            radii=radii,
            displacement=radii - self.radii,
            density=float(np.exp(-0.5 * float(z @ z))),
            status=status,
            method=method,
            solver=solver,
            solve_time=time.perf_counter() - t0,
            active_rows=active,
            normalized_displacement=float(np.sqrt(z @ z)),
        )


def _status_of(violation: float, L: float, rounding: float, status: str, method: str,
               tol: Tolerances) -> str:
    """The rule of ``_Problem.checked_status`` once the violation (metres), the length
    ``L`` and the rounding term are known."""
    if not violation <= tol.agreement * L + rounding:
        raise SolverError(
            f"method {method!r}: the radii violate A r <= b by {violation:.3g} m (tolerance "
            f"{tol.agreement * L + rounding:.3g} m); no answer can be trusted")
    if status == "optimal" and violation > tol.feasibility * L + rounding:
        return "optimal_inaccurate"
    return status


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


_CVXPY_STATUS = {
    "optimal": "optimal",
    "optimal_inaccurate": "optimal_inaccurate",
    "infeasible": "infeasible",
    "infeasible_inaccurate": "infeasible",
    "unbounded": "error",
    "unbounded_inaccurate": "error",
    "user_limit": "error",
    "solver_error": "error",
}


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
        raise RadialError(
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
    """Eq. 17 restricted to the violated hyperplanes (see the module docstring).

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
                raise RadialError(
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
    from .vertices import enumerate_vertices, project_vform

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


def project_radii(
    spheres: Sequence[GaussianSphere] | None = None,
    method: str = "active_set",
    solver: str | None = None,
    check: bool | str = False,
    tol: Tolerances = TOLERANCES,
    *,
    centers: ArrayLike | None = None,
    radii: ArrayLike | None = None,
    sigmas: ArrayLike | None = None,
) -> RadialSolution:
    """Project measured radii onto the restriction polytope in normalised radial space.

    The spheres come either as a sequence of :class:`GaussianSphere` (``project_radii(spheres)``)
    or as arrays, by keyword: ``project_radii(centers=c, radii=r, sigmas=s)`` -- the same
    checks, the same answer, without building sphere objects (the fast way in from numpy; a
    float64 input is checked in plain Python at small n).  Pass one form, not both.

    Parameters
    ----------
    spheres : sequence of GaussianSphere, length n >= 2, optional
        Centres (model landmarks), measured radii and their standard deviations.
    centers : (n, 3) array, keyword only
        Sphere centres, metres (instead of ``spheres``; with ``radii`` and ``sigmas``).
    radii : (n,) array, keyword only
        Measured radii >= 0, metres.
    sigmas : (n,) array or scalar, keyword only
        Standard deviations of the radii, > 0, metres (a scalar applies to every sphere), within
        the relative range of ``sigma_range``.
    method : {"active_set", "cvxpy", "vertices", "paper"}
        Backend, see the module docstring.
    solver : str, optional
        cvxpy solver name for ``method="cvxpy"`` (default ``"CLARABEL"``).
    check : bool or "exact"
        True: verify the answer against explicit vertex enumeration in floating point;
        ``"exact"``: verify it in exact rational arithmetic with pycddlib's GMP mode
        (:func:`verify_solution_exact`; :class:`~radialopt.errors.RadialError` when
        ``cdd.gmp`` is missing).  Either raises :class:`~radialopt.errors.VerificationError`
        on disagreement.
    tol : Tolerances
        Numerical tolerances.

    Returns
    -------
    RadialSolution

    Raises
    ------
    RadialError
        - Bad input (see :mod:`radialopt.errors`), unknown method or solver.
        - ``check`` or ``method="vertices"`` with more than
          :data:`~radialopt.vertices.MAX_VERTEX_SPHERES` spheres (vertex enumeration).
    SolverError
        The backend failed and no answer can be trusted.
    """
    if not (type(method) is str and method == "active_set" and solver is None and check is False
            and type(tol) is Tolerances):
        _check_arguments(method, solver, check, tol)  # the defaults need no check
    if centers is not None or radii is not None or sigmas is not None:
        if spheres is not None:
            raise RadialError("pass either spheres or centers=, radii=, sigmas=, not both (got spheres "
                              f"of type {type(spheres).__name__} and arrays)")
        if centers is None or radii is None or sigmas is None:
            missing = [k for k, v in (("centers", centers), ("radii", radii), ("sigmas", sigmas))
                       if v is None]
            raise RadialError("the array form needs centers=, radii= and sigmas=; missing "
                              f"{', '.join(missing)}")
        c, r, sg = checked_arrays(centers, radii, sigmas, min_count=2)
        return _project_arrays(c, r, sg, method, solver, check, tol)
    if spheres is None:
        raise RadialError("project_radii needs spheres, or centers=, radii= and sigmas= arrays")
    if not isinstance(spheres, (Sequence, str, bytes, GaussianSphere, np.ndarray)) and isinstance(
            spheres, Iterable):
        spheres = list(spheres)  # a generator is read once; check=True reads the spheres again
    c, r, sg = sphere_arrays(spheres, min_count=2, tol=tol, check_centers=False)
    return _project_arrays(c, r, sg, method, solver, check, tol)


def _check_arguments(method: object, solver: object, check: object, tol: object) -> None:
    """The checks of :func:`project_radii`'s arguments other than the spheres."""
    if not isinstance(method, str) or method not in _BACKENDS:
        raise RadialError(f"unknown method {method!r:.100}; choose one of {', '.join(METHODS)}")
    if solver is not None and not isinstance(solver, str):
        raise RadialError(f"solver must be a cvxpy solver name or None, got {solver!r:.100}")
    if solver is not None and method != "cvxpy":
        raise RadialError(f"solver={solver!r} only applies to method='cvxpy', not {method!r}")
    if not (check is False or check is True or (isinstance(check, str) and check == "exact")):
        raise RadialError(f"check must be False, True or 'exact', got check={check!r:.100}")
    instance("tol", tol, Tolerances)
    if check == "exact":
        _cdd_gmp()  # fail before solving when the exact mode is missing


def project_radii_unchecked(
    centers: NDArray[np.float64],
    radii: NDArray[np.float64],
    sigmas: NDArray[np.float64],
    method: str = "active_set",
    solver: str | None = None,
    check: bool | str = False,
    tol: Tolerances = TOLERANCES,
) -> RadialSolution:
    """:func:`project_radii` without its input checks, for internal callers whose data were
    checked where they were made (worldgraph's localize, the range-only estimators).

    The same computation and the same answer as ``project_radii(make_spheres(centers, radii,
    sigmas), method, solver, check, tol)``; only the validation is skipped.  The caller
    guarantees: ``centers`` a float64 ``(n, 3)`` array and ``radii``, ``sigmas`` float64
    ``(n,)`` arrays with ``n >= 2``, all finite, radii >= 0, sigmas > 0 within the relative
    range ``sigma_range`` accepts, and ``method``, ``solver``,
    ``check``, ``tol`` valid arguments of :func:`project_radii`.  Coincident centres still
    raise :class:`~radialopt.errors.RadialError` (the pair distances are computed
    anyway); anything else outside the contract gives undefined results.
    """
    return _project_arrays(centers, radii, sigmas, method, solver, check, tol)


def _project_arrays(
    centers: NDArray[np.float64], radii: NDArray[np.float64], sigmas: NDArray[np.float64],
    method: str, solver: str | None, check: bool | str, tol: Tolerances,
) -> RadialSolution:
    """:func:`project_radii` after its input checks (shared with ``project_radii_unchecked``)."""
    n = len(radii)
    if check is not False or method == "vertices":
        from .vertices import check_vertex_spheres

        what = f"check={check!r}" if check is not False else "method='vertices'"
        check_vertex_spheres(n, f"spheres ({what} enumerates vertices)")
    t0 = time.perf_counter()
    problem = None
    if method == "active_set" and n <= SMALL_CORE_SPHERES:
        sol = _active_set_small(centers, radii, sigmas, tol, t0)
    else:
        problem = _Problem.from_arrays(centers, radii, sigmas, tol)
        z, status = _BACKENDS[method](problem, solver, tol)
        if status == "infeasible" or not np.all(np.isfinite(z)):
            raise SolverError(f"method {method!r} found no feasible radii (status {status!r})")
        solver_name = ("CLARABEL" if solver is None else solver.upper()) if method == "cvxpy" else None
        status = problem.checked_status(z, status, method, tol)
        sol = problem.solution(z, status, method, solver_name, t0)
    if check is not False:
        if problem is None:
            problem = _Problem.from_arrays(centers, radii, sigmas, tol)
        if check == "exact":
            _verify_exact(problem, sol, tol)
        else:
            _verify(problem, sol, tol)
    return sol


def _active_set_small(
    centers: NDArray[np.float64], radii: NDArray[np.float64], sigmas: NDArray[np.float64],
    tol: Tolerances, t0: float,
) -> RadialSolution:
    """``method="active_set"`` for at most ``SMALL_CORE_SPHERES`` spheres in plain Python:
    the rows of ``_pair_rows``, the dual active set ``_ldp_pairs`` (the NNLS route of
    :func:`least_distance` when it does not certify), and the status rule and result of
    ``_Problem.checked_status`` and ``_Problem.solution``; ``G z - h = A r' - b``
    gives the violation in metres and the slacks from one pass over the rows."""
    r = radii.tolist()
    s = sigmas.tolist()
    n = len(r)
    rows, dist, setup = _pair_setup(centers.tolist(), r, s, tol, centers)
    status = "optimal"
    out = _ldp_pairs(rows, n, setup)
    if out is None:  # not certified: the NNLS route decides
        G = np.zeros((len(rows), n))
        for k, (i, j, a, b, _) in enumerate(rows):
            G[k, i], G[k, j] = a, b
        z_arr, status = least_distance(G, np.array([row[4] for row in rows]))
        z = z_arr.tolist()
        if status == "infeasible" or not all(map(math.isfinite, z)):
            raise SolverError(f"method 'active_set' found no feasible radii (status {status!r})")
        excess = [a * z[i] + b * z[j] - hk for i, j, a, b, hk in rows]
    else:
        z, excess = out  # excess = G z - h = A r' - b, metres
    new = [ri + si * zi for ri, si, zi in zip(r, s, z, strict=True)]
    if not math.isfinite(sum(new)) and not all(map(math.isfinite, new)):
        raise SolverError(f"method 'active_set': non-finite radii {new}")
    d_max = max(dist)
    r_max = max(r)  # radii >= 0
    L = max(d_max, max(new), -min(new), 1.0)
    worst = max(excess)
    if not worst <= min(tol.feasibility, tol.agreement) * L:  # else within both: the status stays
        status = _status_of(worst, L, RADIUS_ROUNDING * r_max, status, "active_set", tol)
    cut = ACTIVE_SLACK * max(d_max, r_max, 1.0)
    zz = _dot(z, z)
    new_arr = np.array(new)
    return _radial_solution(
        new_arr, new_arr - radii, math.exp(-0.5 * zz),
        status, time.perf_counter() - t0, tuple([k for k, e in enumerate(excess) if -cut <= e <= cut]),
        math.sqrt(zz))


def _radial_solution(radii: NDArray[np.float64], displacement: NDArray[np.float64], density: float,
                     status: str, solve_time: float, active_rows: tuple[int, ...],
                     normalized_displacement: float) -> RadialSolution:
    """An ``"active_set"`` :class:`RadialSolution` without the frozen dataclass's per-field
    ``object.__setattr__`` (the same object; a microsecond less at small n)."""
    sol = object.__new__(RadialSolution)
    sol.__dict__.update(radii=radii, displacement=displacement, density=density, status=status,
                        method="active_set", solver=None, solve_time=solve_time, active_rows=active_rows,
                        normalized_displacement=normalized_displacement)
    return sol


@dataclass(frozen=True)
class BatchSolution:
    """Result of :func:`project_radii_batch`: arrays over B instances."""

    radii: NDArray[np.float64]
    density: NDArray[np.float64]
    normalized_displacement: NDArray[np.float64]
    solve_time: float


def project_radii_batch(
    centers: ArrayLike, radii: ArrayLike, sigmas: ArrayLike, tol: Tolerances = TOLERANCES
) -> BatchSolution:
    """Exact projection of B instances at once, vectorised across the instances.

    Up to ``SMALL_CORE_SPHERES`` spheres every instance is solved by the dual active-set
    method of ``_ldp_pairs`` run on all instances together in
    numpy (``_batch_dual_active_set``: one step of every unfinished instance per pass, its
    working set held in n slots, the working rows' Gram systems solved as one stacked
    ``(B, n, n)`` solve).  An instance that does not settle there (a violated row dependent on
    its working rows, a singular working set, more steps than the budget) and every instance of
    more spheres is solved alone by the single-instance route (``project_radii(...,
    method="active_set")``), the reference the vectorised path is tested against.  Each answer
    is the unique optimum; the radii must satisfy ``A r <= b`` to ``tol.agreement`` times the
    instance's length scale, else :class:`~radialopt.errors.SolverError`.

    Parameters
    ----------
    centers : (B, n, 3) float
    radii, sigmas : (B, n) float
        Checked as by :func:`project_radii` (errors name the instance and sphere, e.g.
        ``radii[3, 1]``).

    Returns
    -------
    BatchSolution with ``radii (B, n)``, ``density (B,)``, ``normalized_displacement (B,)``.
    """
    instance("tol", tol, Tolerances)
    c = real_array("centers", centers, shape=("B", "n", 3))
    if c.shape[1] < 2:
        raise RadialError(f"centers must have shape (B, n, 3) with n >= 2, got shape {c.shape}")
    r = real_array("radii", radii, shape=c.shape[:2])
    sg = real_array("sigmas", sigmas, shape=c.shape[:2], max_abs=MAX_SIGMA)
    if np.any(sg <= 0):
        raise RadialError(f"sigmas{np.argwhere(sg <= 0)[0].tolist()} = {float(sg[sg <= 0][0])!r} "
                          "must be > 0")
    if np.any(r < 0):
        raise RadialError(
            f"radii{np.argwhere(r < 0)[0].tolist()} = {float(r[r < 0][0])!r} must be >= 0")
    if c.shape[0]:
        scale = np.maximum(np.maximum(np.abs(c).max(axis=(1, 2)), r.max(axis=1)), 1.0)[:, None]
        bad = np.flatnonzero(np.any((sg < MIN_SIGMA_RELATIVE * scale) | (sg > scale / MIN_SIGMA_RELATIVE),
                                    axis=1))
        if bad.size:  # sigma_range names the sphere
            b0 = int(bad[0])
            sigma_range(f"sigmas[{b0}]", sg[b0], max(float(np.abs(c[b0]).max()), float(r[b0].max())))
    t0 = time.perf_counter()
    z, d, h = _batch_solve(c, r, sg, tol)
    _batch_check(z, d, h, r, sg, tol)
    zz = np.sum(z * z, axis=1)
    return BatchSolution(r + sg * z, np.exp(-0.5 * zz), np.sqrt(zz), time.perf_counter() - t0)


#: Instances per pass of ``_batch_dual_active_set`` (bounds its temporaries).
BATCH_CHUNK = 16384


def _batch_solve(
    c: NDArray[np.float64], r: NDArray[np.float64], sg: NDArray[np.float64], tol: Tolerances
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Whitened answers ``z (B, n)``, pair distances ``d (B, p)`` and ``h (B, m)`` of checked arrays."""
    n = c.shape[1]
    iu, ju, A, b_sign = pair_pattern(n)
    d = np.sqrt(np.sum((c[:, iu] - c[:, ju]) ** 2, axis=2))  # (B, p)
    if np.any(d <= tol.coincident):
        k = int(np.argwhere(d <= tol.coincident)[0, 0])
        check_distinct_centers(c[k], tol)
    # a C-contiguous A^T: numpy's matmul with the transposed view took 30x longer at (10^4, 4)
    h = b_sign * np.repeat(d, 3, axis=1) - r @ np.ascontiguousarray(A.T)  # (B, m)
    z = np.zeros_like(r)
    todo = np.flatnonzero(h.min(axis=1) < 0)  # the others: z = 0 exactly
    failed: list[NDArray[np.int64]] = []
    if n <= SMALL_CORE_SPHERES:
        for lo in range(0, len(todo), BATCH_CHUNK):
            idx = todo[lo:lo + BATCH_CHUNK]
            zk, ok = _batch_dual_active_set(A, sg[idx], h[idx])
            z[idx[ok]] = zk[ok]
            failed.append(idx[~ok])
        todo = np.concatenate(failed) if failed else todo[:0]
    for k in map(int, todo):  # the single-instance route
        z[k] = (project_radii_unchecked(c[k], r[k], sg[k], tol=tol).radii - r[k]) / sg[k]
    return z, d, h


def _batch_check(z: NDArray[np.float64], d: NDArray[np.float64], h: NDArray[np.float64],
                 r: NDArray[np.float64], sg: NDArray[np.float64], tol: Tolerances) -> None:
    """:class:`SolverError` naming the first instance whose radii violate ``A r <= b`` by more than
    ``tol.agreement`` times its length scale, or that are not finite."""
    if not z.size:
        return
    A = pair_pattern(z.shape[1])[2]
    violation = np.max((sg * z) @ np.ascontiguousarray(A.T) - h, axis=1)
    scale = np.maximum(np.maximum(d.max(axis=1), r.max(axis=1)), 1.0)
    bad = np.flatnonzero(~(violation <= tol.agreement * scale) | ~np.all(np.isfinite(z), axis=1))
    if bad.size:
        k = int(bad[0])
        raise SolverError(f"instance {k}: the radii violate A r <= b by {violation[k]:.3g} m "
                          f"(tolerance {tol.agreement * scale[k]:.3g} m; sigmas {sg[k].tolist()})")


def _batch_dual_active_set(
    A: NDArray[np.float64], sg: NDArray[np.float64], h: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """``min |z|^2 s.t. G_k z <= h_k`` with ``G_k = A diag(sg_k)`` for K instances at once.

    The dual active-set method of ``_ldp_pairs`` (Goldfarb and
    Idnani with the identity Hessian, the same steps and tolerances), vectorised: each
    instance keeps its working rows in n slots (``W (K, n, n)``, empty slots zero, their Gram
    diagonal one), and every pass makes one step of every unfinished instance -- pick the most
    violated row if none is being added, else move along its direction projected onto the
    working rows' null space, to the full step (the row joins a free slot) or the partial one
    (the working row whose multiplier reaches zero first leaves).  Finished instances leave the
    arrays.  Returns ``(z (K, n), ok (K,))``; ``ok`` is False where the loop did not certify a
    KKT point (the caller solves those alone).
    """
    K, n = sg.shape
    z_out = np.zeros((K, n))
    ok_out = np.zeros(K, dtype=bool)
    live = np.arange(K)
    tol = ROUNDING_RTOL * np.maximum(np.abs(h).max(axis=1), 1.0)
    z = np.zeros((K, n))
    W = np.zeros((K, n, n))
    act = np.zeros((K, n), dtype=bool)
    u = np.zeros((K, n))
    cur = np.full(K, -1)
    up = np.zeros(K)
    eye = np.eye(n, dtype=bool)
    AT = np.ascontiguousarray(A.T)
    # the first step in closed form: from z = 0 the most violated row joins the empty working
    # set with the full step t = -h_p / |g_p|^2 (instances with no violated row are done, z = 0)
    p0 = np.argmax(-h, axis=1)
    h0 = h[live, p0]
    gp0 = A[p0] * sg
    t0 = -h0 / np.sum(gp0 * gp0, axis=1)
    start = -h0 > tol
    z[start] = -t0[start, None] * gp0[start]
    W[start, 0] = gp0[start]
    act[start, 0] = True
    u[start, 0] = t0[start]
    for _ in range(4 * A.shape[0] + 8):
        if not len(live):
            break
        # instances between rows: done, or the most violated row starts to join
        pick = np.flatnonzero(cur < 0)
        out = np.zeros(len(live), dtype=bool)
        if len(pick):
            excess = (sg[pick] * z[pick]) @ AT - h[pick]
            p = np.argmax(excess, axis=1)
            done = excess[np.arange(len(p)), p] <= tol[pick]
            cur[pick[~done]] = p[~done]
            up[pick[~done]] = 0.0
            fin = pick[done]
            if len(fin):
                out[fin] = True
                ok_out[live[fin]] = np.all(~act[fin] | (u[fin] >= -tol[fin, None]), axis=1)
                z_out[live[fin]] = z[fin]
        if np.any(out):
            keep = ~out
            live, z, W, act, u = live[keep], z[keep], W[keep], act[keep], u[keep]
            cur, up, sg, h, tol = cur[keep], up[keep], sg[keep], h[keep], tol[keep]
            if not len(live):
                break
        # one step of every live instance along its row cur
        rows = np.arange(len(live))
        gp = A[cur] * sg
        gram = W @ W.transpose(0, 2, 1)
        gram[:, eye] += ~act
        try:
            rr = np.linalg.solve(gram, np.einsum("kij,kj->ki", W, gp)[..., None])[..., 0]
        except np.linalg.LinAlgError:
            break  # a singular working set: every live instance is left to the caller
        w = gp - np.einsum("ki,kij->kj", rr, W)
        gd = np.sum(w * w, axis=1)
        pos = act & (rr > 0.0)
        ratio = np.full(act.shape, np.inf)
        np.divide(u, rr, out=ratio, where=pos)
        kd = np.argmin(ratio, axis=1)
        t1 = ratio[rows, kd]
        dependent = gd <= RANK_RTOL * np.sum(gp * gp, axis=1)
        stuck = (dependent & ~np.isfinite(t1)) | ~np.all(np.isfinite(rr), axis=1)
        t2 = np.full(len(live), np.inf)
        np.divide(np.sum(gp * z, axis=1) - h[rows, cur], gd, out=t2, where=~dependent)
        t = np.minimum(t1, t2)
        t[stuck] = 0.0
        z -= np.where(dependent, 0.0, t)[:, None] * w
        u -= t[:, None] * np.where(act, rr, 0.0)
        up += t
        full = (t2 <= t1) & ~stuck
        slot = np.where(full, np.argmin(act, axis=1), kd)
        f, fs = rows[full], slot[full]
        act[f, fs] = True
        u[f, fs] = up[full]
        W[f, fs] = gp[full]
        drop = ~full & ~stuck
        dr, ds = rows[drop], slot[drop]
        act[dr, ds] = False
        u[dr, ds] = 0.0
        W[dr, ds] = 0.0
        cur[full] = -1
        if np.any(stuck):  # left to the caller (ok_out stays False)
            keep = ~stuck
            live, z, W, act, u = live[keep], z[keep], W[keep], act[keep], u[keep]
            cur, up, sg, h, tol = cur[keep], up[keep], sg[keep], h[keep], tol[keep]
    return z_out, ok_out


def _project_radii_batch_reference(
    c: NDArray[np.float64], r: NDArray[np.float64], sg: NDArray[np.float64], tol: Tolerances = TOLERANCES
) -> NDArray[np.float64]:
    """The slow, obvious batch: one single-instance solve per instance (checked arrays);
    the adjusted radii ``(B, n)``.  :func:`project_radii_batch` is tested against it."""
    out = np.empty_like(r)
    for k in range(len(r)):
        out[k] = project_radii_unchecked(c[k], r[k], sg[k], tol=tol).radii
    return out


def verify_solution(
    spheres: Sequence[GaussianSphere], sol: RadialSolution, tol: Tolerances = TOLERANCES
) -> None:
    """Check a solution against explicit vertex enumeration; raise VerificationError if wrong.

    Two independent checks: the V-form optimality certificate of the returned radii (they lie
    in the polytope and no vertex or ray improves on them), and agreement with the V-form
    optimum.  The paper's method is only checked for feasibility and for not beating the
    optimum, since it is not optimal by design.
    """
    _verify(_Problem.build(spheres, tol), sol, tol)


def _verify(problem: _Problem, sol: RadialSolution, tol: Tolerances) -> None:
    """:func:`verify_solution` of a built instance."""
    from .vertices import certify_projection, enumerate_vertices, project_vform

    enum = enumerate_vertices(problem.polytope)
    ref, _ = project_vform(enum, problem.radii, problem.sigmas)
    ref_cost = float(np.sum(((ref - problem.radii) / problem.sigmas) ** 2))
    cost = float(np.sum(((sol.radii - problem.radii) / problem.sigmas) ** 2))
    atol = tol.agreement * problem.scale
    if not problem.polytope.contains(sol.radii, atol):
        rows = problem.polytope.violated_rows(sol.radii, atol)
        raise VerificationError(f"{sol.method}: radii {sol.radii.tolist()} violate {rows}")
    if cost < ref_cost - tol.agreement * max(ref_cost, 1.0):
        raise VerificationError(
            f"{sol.method}: cost {cost:.12g} below the vertex-enumeration optimum {ref_cost:.12g}"
        )
    if sol.method == "paper":
        return
    ok, residual, message = certify_projection(
        enum, problem.polytope, problem.radii, problem.sigmas, sol.radii, atol
    )
    gap = float(np.max(np.abs(sol.radii - ref)))
    if not ok or gap > atol:
        raise VerificationError(
            f"{sol.method}: radii {sol.radii.tolist()} differ from the vertex-enumeration "
            f"optimum {ref.tolist()} by {gap:.3g} m (tolerance {atol:.3g}); certificate: {message}"
        )


# ------------------------------------------------------------------------ exact check
def verify_solution_exact(
    spheres: Sequence[GaussianSphere], sol: RadialSolution, tol: Tolerances = TOLERANCES
) -> None:
    """``check="exact"``: verify a solution against vertex enumeration in rational arithmetic.

    The float data (``A``, ``b`` from the centre distances, radii, sigmas and the answer) are
    read as exact Fractions, the polyhedron's vertices and rays are enumerated exactly by
    pycddlib's GMP mode, and:

    1. the returned radii satisfy ``A x <= b + atol`` (exactly evaluated);
    2. the rows tight at the answer (slack <= atol) define, exactly, the sigma-weighted
       projection ``x*`` of the measured radii onto their affine hull; ``x*`` must lie in the
       polyhedron exactly and satisfy the variational inequality
       ``(x* - r)/sigma^2 . (v - x*) >= 0`` for every exact vertex v and ``. d >= 0`` for every
       ray d -- an exact certificate that ``x*`` is *the* optimum;
    3. the returned radii are within ``atol = tol.agreement * scale`` of ``x*``.

    Raises
    ------
    RadialError
        pycddlib's GMP mode (``cdd.gmp``) is not installed.
    VerificationError
        Any of the three conditions fails.
    """
    _verify_exact(_Problem.build(spheres, tol), sol, tol)


def _verify_exact(problem: _Problem, sol: RadialSolution, tol: Tolerances) -> None:
    """:func:`verify_solution_exact` of a built instance."""
    P = problem.polytope
    A = [[Fraction(int(a)) if float(a).is_integer() else Fraction(float(a)) for a in row]
         for row in np.asarray(P.A)]
    b = [Fraction(float(v)) for v in P.b]
    r = [Fraction(float(v)) for v in problem.radii]
    s2 = [Fraction(float(v)) ** 2 for v in problem.sigmas]
    x = [Fraction(float(v)) for v in sol.radii]
    n = len(r)
    atol = Fraction(tol.agreement * problem.scale)
    vertices, rays = _exact_generators(A, b)
    slack = [b[i] - sum(A[i][t] * x[t] for t in range(n)) for i in range(len(b))]
    worst = min(range(len(b)), key=lambda i: slack[i])
    if slack[worst] < -atol:
        raise VerificationError(
            f"{sol.method} (exact check): radii violate row {worst} by {float(-slack[worst]):.3g} "
            f"(tolerance {float(atol):.3g})")
    if sol.method == "paper":
        return
    candidates = [[i for i in range(len(b)) if abs(slack[i]) <= atol], list(sol.active_rows)]
    for active in candidates:
        xs = _exact_kkt_point(A, b, r, s2, active)
        if xs is None or any(sum(A[i][t] * xs[t] for t in range(n)) > b[i] for i in range(len(b))):
            continue
        g = [(xs[t] - r[t]) / s2[t] for t in range(n)]
        gx = sum(g[t] * xs[t] for t in range(n))
        if any(sum(g[t] * v[t] for t in range(n)) < gx for v in vertices):
            continue
        if any(sum(g[t] * d[t] for t in range(n)) < 0 for d in rays):
            continue
        gap = max(abs(x[t] - xs[t]) for t in range(n))
        if gap > atol:
            raise VerificationError(
                f"{sol.method} (exact check): radii {sol.radii.tolist()} differ from the exact "
                f"optimum {[float(v) for v in xs]} by {float(gap):.3g} m (tolerance "
                f"{float(atol):.3g})")
        return
    raise VerificationError(
        f"{sol.method} (exact check): the facets tight at radii {sol.radii.tolist()} do not give "
        f"an exactly optimal point over the {len(vertices)} exact vertices and {len(rays)} rays; "
        "the answer is not the optimum within tolerance")
