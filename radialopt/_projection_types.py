"""The types every method of the radial projection (:mod:`radialopt.projection`) shares with
:mod:`radialopt.formulation` and :mod:`radialopt.comparison`: the status set, the answer
:class:`RadialSolution`, the whitened instance ``_Problem`` (its status rule ``_status_of``) and
the map of cvxpy's statuses onto the status set (``_CVXPY_STATUS``)."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Literal, get_args

import numpy as np
from numpy.typing import NDArray

from .errors import SolverError
from .polytope import RestrictionPolytope, pair_pattern
from .spheres import (
    GaussianSphere,
    Tolerances,
    check_distinct_centers,
    sphere_arrays,
)
from .tolerances import ACTIVE_SLACK, RADIUS_ROUNDING

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
