"""The single-instance entry points: :func:`project_radii` (spheres or checked arrays in, one
:class:`~radialopt.projection.RadialSolution` out) and ``project_radii_unchecked`` (the same
computation without the input checks); the small-instance ``"active_set"`` route runs here in
plain Python, the other methods through :mod:`radialopt.projection.backends`."""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._checks import instance
from .._dual_active_set import SMALL_CORE_SPHERES, _dot, _ldp_pairs, _pair_setup
from .._exact_check import _cdd_gmp
from .._ldp import least_distance
from .._projection_types import RadialSolution, _Problem, _status_of
from ..errors import RadialArgumentError, SolverError
from ..spheres import (
    TOLERANCES,
    GaussianSphere,
    Tolerances,
    checked_arrays,
    sphere_arrays,
)
from ..tolerances import ACTIVE_SLACK, RADIUS_ROUNDING
from .backends import _BACKENDS, METHODS
from .verify import _verify, _verify_exact

__all__ = ["project_radii"]


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
        Backend, see :mod:`radialopt.projection`.
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
            raise RadialArgumentError("pass either spheres or centers=, radii=, sigmas=, not both (got "
                                      f"spheres of type {type(spheres).__name__} and arrays)")
        if centers is None or radii is None or sigmas is None:
            missing = [k for k, v in (("centers", centers), ("radii", radii), ("sigmas", sigmas))
                       if v is None]
            raise RadialArgumentError("the array form needs centers=, radii= and sigmas=; missing "
                                      f"{', '.join(missing)}")
        c, r, sg = checked_arrays(centers, radii, sigmas, min_count=2)
        return _project_arrays(c, r, sg, method, solver, check, tol)
    if spheres is None:
        raise RadialArgumentError("project_radii needs spheres, or centers=, radii= and sigmas= arrays")
    if not isinstance(spheres, (Sequence, str, bytes, GaussianSphere, np.ndarray)) and isinstance(
            spheres, Iterable):
        spheres = list(spheres)  # a generator is read once; check=True reads the spheres again
    c, r, sg = sphere_arrays(spheres, min_count=2, tol=tol, check_centers=False)
    return _project_arrays(c, r, sg, method, solver, check, tol)


def _check_arguments(method: object, solver: object, check: object, tol: object) -> None:
    """The checks of :func:`project_radii`'s arguments other than the spheres."""
    if not isinstance(method, str) or method not in _BACKENDS:
        raise RadialArgumentError(f"unknown method {method!r:.100}; choose one of {', '.join(METHODS)}")
    if solver is not None and not isinstance(solver, str):
        raise RadialArgumentError(f"solver must be a cvxpy solver name or None, got {solver!r:.100}")
    if solver is not None and method != "cvxpy":
        raise RadialArgumentError(f"solver={solver!r} only applies to method='cvxpy', not {method!r}")
    if not (check is False or check is True or (isinstance(check, str) and check == "exact")):
        raise RadialArgumentError(f"check must be False, True or 'exact', got check={check!r:.100}")
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
        from ..vertices import check_vertex_spheres

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
