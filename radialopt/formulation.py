"""A reusable cvxpy formulation of the radial projection for research code.

:class:`RadialProblem` builds, once per sphere count n, the design card's problem as a DPP
(disciplined parametrised) cvxpy problem::

    minimise   phi(w * x - t)          w = 1 / sigma, t = r / sigma (parameters)
    subject to A x <= b                A fixed for n, b from the centre distances (parameter)
               + any constraints the caller adds

with ``phi`` the squared 2-norm (``"l2"``, the Gaussian density of :func:`project_radii`),
the 1-norm (``"l1"``) or the Huber function (``"huber"``, quadratic up to ``huber_delta``
sigma, linear beyond).  cvxpy compiles the problem on its first solve and re-uses the
compilation for every later instance of the same size; adding a constraint rebuilds it (one
recompilation at the next solve).

Example::

    rp = RadialProblem(5, objective="huber", huber_delta=2.0)
    rp.bound_radii(0.0, 10.0)
    sol = rp.solve(spheres)          # a RadialSolution, status as in project_radii
"""

from __future__ import annotations

import contextlib
import io
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ._checks import MAX_LENGTH, instance, integer, real_array, real_scalar
from ._projection_types import _CVXPY_STATUS, _Problem
from .errors import (
    RadialArgumentError,
    RadialError,
    SolverError,
)
from .polytope import pair_pattern
from .projection import RadialSolution, installed_cvxpy_solvers, solver_options
from .spheres import TOLERANCES, GaussianSphere, Tolerances

#: Objectives accepted by :class:`RadialProblem`.
OBJECTIVES = ("l2", "l1", "huber")
#: Most spheres a RadialProblem accepts (3 C(64, 2) = 6048 rows).
MAX_SPHERES = 64


class RadialProblem:
    """The radial projection for ``n`` spheres as a DPP cvxpy problem, compiled once.

    Parameters
    ----------
    n : int
        Number of spheres (>= 2).
    objective : {"l2", "l1", "huber"}
        Penalty on the whitened displacement ``(x - r) / sigma``.
    huber_delta : float
        Huber threshold in sigma units (``objective="huber"``), > 0.

    Attributes
    ----------
    problem : cvxpy.Problem
        The current problem (rebuilt when a constraint is added).
    parameters : dict of str -> cvxpy.Parameter
        ``"b"`` (m,) restriction right-hand sides, ``"inv_sigma"`` (n,) ``1/sigma``,
        ``"scaled_radii"`` (n,) ``r/sigma``.
    variables : dict of str -> cvxpy.Variable
        ``"radii"`` (n,): the adjusted radii.
    A : (m, n) ndarray
        The fixed restriction rows for n spheres (``m = 3 n (n - 1) / 2``).
    compilations : int
        How many times the cvxpy problem has been (re)built.
    """

    def __init__(self, n: int, objective: str = "l2", huber_delta: float = 1.0) -> None:
        import cvxpy as cp

        n = integer("n", n)
        if n < 2:
            raise RadialArgumentError(f"n must be >= 2 spheres, got n={n}")
        if n > MAX_SPHERES:
            raise RadialArgumentError(f"n = {n} spheres: the formulation has 3 C(n, 2) rows; at most "
                                      f"{MAX_SPHERES} spheres are accepted")
        if not isinstance(objective, str) or objective not in OBJECTIVES:
            raise RadialArgumentError(
                f"unknown objective={objective!r:.100}; choose one of {', '.join(OBJECTIVES)}")
        delta = real_scalar("huber_delta", huber_delta, positive=True, maximum=MAX_LENGTH)
        self.n = int(n)
        self.objective = objective
        self.huber_delta = delta
        _, _, A, _ = pair_pattern(self.n)
        self.A = np.asarray(A, dtype=np.float64)
        self.variables = {"radii": cp.Variable(self.n, name="radii")}
        self.parameters = {
            "b": cp.Parameter(self.A.shape[0], name="b"),
            "inv_sigma": cp.Parameter(self.n, pos=True, name="inv_sigma"),
            "scaled_radii": cp.Parameter(self.n, name="scaled_radii"),
        }
        self._extra: list[Callable[[Any], Any]] = []
        self._labels: list[str] = []  # what each entry of _extra came from (for messages)
        self.compilations = 0
        self._build()

    # ------------------------------------------------------------------ construction
    def _build(self) -> None:
        import cvxpy as cp

        x = self.variables["radii"]
        par = self.parameters
        resid = cp.multiply(par["inv_sigma"], x) - par["scaled_radii"]
        if self.objective == "l2":
            cost = cp.sum_squares(resid)
        elif self.objective == "l1":
            cost = cp.norm1(resid)
        else:
            # cvxpy annotates huber's M as int, but it takes any positive number (its docs).
            cost = cp.sum(cp.huber(resid, self.huber_delta))  # type: ignore[arg-type]
        constraints = [self.A @ x <= par["b"]]
        for fn in self._extra:
            constraints += _as_constraints(fn(x))
        self.problem = cp.Problem(cp.Minimize(cost), constraints)
        if not self.problem.is_dpp():
            raise RadialArgumentError("the added constraints make the problem not DPP (parameters may "
                                      "only enter affinely); build them from constants and the variable")
        self.compilations += 1

    @property
    def radii(self) -> Any:
        """The cvxpy variable of the adjusted radii (what constraint callables receive)."""
        return self.variables["radii"]

    def add_constraint(self, fn: Callable[[Any], Any]) -> RadialProblem:
        """Add the constraints ``fn(radii_variable)`` (one constraint or a list); rebuilds the
        problem once.  Returns self, so calls chain."""
        if not callable(fn):
            raise RadialArgumentError(
                f"fn must be a callable of the radius variable, got {type(fn).__name__}")
        try:
            out = fn(self.variables["radii"])
        except RadialError:
            raise
        except Exception as exc:  # the caller's callable: its failure is a bad fn argument
            raise RadialArgumentError(
                f"fn raised {type(exc).__name__} on the radius variable: {exc}") from exc
        cons = _as_constraints(out)
        if not cons:
            raise RadialArgumentError("fn returned no cvxpy constraint")
        name = getattr(fn, "__name__", type(fn).__name__)
        return self._add(fn, f"add_constraint #{len(self._extra) + 1} ({name})")

    def _add(self, fn: Callable[[Any], Any], label: str) -> RadialProblem:
        """Append a constraint callable with the label infeasibility messages show; rebuild."""
        self._extra.append(fn)
        self._labels.append(label)
        try:
            self._build()
        except RadialError:
            self._extra.pop()
            self._labels.pop()
            self._build()
            raise
        return self

    def bound_radii(self, lo: ArrayLike = 0.0, hi: ArrayLike = np.inf) -> RadialProblem:
        """Constrain ``lo <= radii <= hi`` (scalars or (n,) arrays, metres; ``-inf``/``inf`` to
        leave a side open)."""
        lo_a = self._vector(lo, "lo")
        hi_a = self._vector(hi, "hi")
        if np.any(lo_a > hi_a):
            k = int(np.argmax(lo_a > hi_a))
            raise RadialArgumentError(f"lo must be <= hi; lo[{k}]={lo_a[k]!r} > hi[{k}]={hi_a[k]!r}")
        lo_i, hi_i = np.flatnonzero(np.isfinite(lo_a)), np.flatnonzero(np.isfinite(hi_a))

        def bounds(x: Any) -> list:
            out = []
            if lo_i.size:
                out.append(x[lo_i] >= lo_a[lo_i])
            if hi_i.size:
                out.append(x[hi_i] <= hi_a[hi_i])
            return out

        if lo_i.size == 0 and hi_i.size == 0:
            raise RadialArgumentError("bound_radii with lo=-inf and hi=inf adds nothing")

        def show(a: np.ndarray) -> str:
            return repr(float(a[0])) if np.all(a == a[0]) else repr(a.tolist())

        return self._add(bounds, f"bound_radii(lo={show(lo_a)}, hi={show(hi_a)})")

    def fix_radius(self, i: int, value: float) -> RadialProblem:
        """Constrain ``radii[i] == value`` (metres)."""
        i = integer("i", i)
        if not 0 <= i < self.n:  # no wrap-around: i = -1 is a caller's bug, not the last sphere
            raise RadialArgumentError(f"i = {i!r} must be a sphere index in [0, {self.n})")
        v = real_scalar("value", value, minimum=0.0, max_abs=MAX_LENGTH)  # a radius, metres
        return self._add(lambda x: [x[i] == v], f"fix_radius(i={i}, value={v!r})")

    def _vector(self, v: ArrayLike, name: str) -> np.ndarray:
        """``v`` (scalar or (n,)) as an (n,) float array: real, not NaN, finite values of at most
        MAX_LENGTH metres; +-inf allowed (an open side)."""
        try:
            raw = np.asarray(v)
        except (TypeError, ValueError, OverflowError):  # ragged or odd: real_array names the fault
            raw = np.zeros(0)
        is_open = np.isinf(raw) if raw.dtype.kind == "f" else np.zeros(raw.shape, dtype=bool)
        if is_open.any():  # +-inf is an open side; the rest is checked as real_array checks any array
            arr = np.where(is_open, raw, real_array(name, np.where(is_open, 0.0, raw), ndim=(0, 1)))
        else:
            arr = real_array(name, v, ndim=(0, 1))
        if arr.ndim == 1 and arr.shape != (self.n,):
            raise RadialArgumentError(f"{name} must be a scalar or shape ({self.n},), got shape {arr.shape}")
        return np.broadcast_to(arr, (self.n,)).copy()

    # ------------------------------------------------------------------------ solving
    def set_parameters(self, spheres: Sequence[GaussianSphere], tol: Tolerances = TOLERANCES) -> Any:
        """Load an instance into the parameters; returns the whitened instance used by
        :func:`project_radii` (centres, radii, sigmas)."""
        if not isinstance(spheres, Sequence) or len(spheres) != self.n:
            got = len(spheres) if isinstance(spheres, Sequence) else type(spheres).__name__
            raise RadialArgumentError(f"spheres must be a sequence of {self.n} GaussianSphere, got {got}")
        inst = _Problem.build(spheres, tol)
        self.parameters["b"].value = inst.b
        self.parameters["inv_sigma"].value = 1.0 / inst.sigmas
        self.parameters["scaled_radii"].value = inst.radii / inst.sigmas
        return inst

    def solve(
        self, spheres: Sequence[GaussianSphere], solver: str = "CLARABEL",
        tol: Tolerances = TOLERANCES, **opts: Any,
    ) -> RadialSolution:
        """Solve for one instance of n spheres; returns a :class:`RadialSolution`.

        ``status`` is ``"optimal"`` or ``"optimal_inaccurate"`` (kept distinct, as in
        :func:`project_radii`); ``density`` and ``normalized_displacement`` are those of the
        Gaussian (l2) model whatever the objective.  ``opts`` go to cvxpy's ``solve`` on top of
        the tight defaults of :func:`radialopt.projection.solver_options`.

        Raises
        ------
        RadialError
            - ``spheres`` is not n spheres.
            - ``solver`` is not an installed cvxpy solver.
        SolverError
            No answer (infeasible added constraints, solver failure).
        """
        import cvxpy as cp

        if not isinstance(solver, str):
            raise RadialArgumentError(f"solver must be a cvxpy solver name, got {solver!r:.100}")
        instance("tol", tol, Tolerances)
        name = solver.upper()
        if name not in installed_cvxpy_solvers():
            raise RadialArgumentError(
                f"solver={solver!r} is not an installed cvxpy solver; installed: "
                f"{', '.join(installed_cvxpy_solvers())}")
        inst = self.set_parameters(spheres, tol)
        kwargs = {**solver_options(name), **opts}
        t0 = time.perf_counter()
        try:
            if name == "OSQP":
                with contextlib.redirect_stdout(io.StringIO()):
                    self.problem.solve(solver=name, **kwargs)
            else:
                self.problem.solve(solver=name, **kwargs)
        except cp.error.SolverError as exc:
            raise SolverError(f"cvxpy solver {name} failed: {exc}") from exc
        status = _CVXPY_STATUS.get(str(self.problem.status), "error")
        x = self.variables["radii"].value
        if status in ("error", "infeasible") or x is None:
            added = "; ".join(self._labels) if self._labels else "none"
            cause = (f"the added constraints [{added}] are incompatible with the restriction "
                     "polytope of these centres (or with each other)" if status == "infeasible"
                     else f"added constraints: [{added}]")
            raise SolverError(
                f"RadialProblem(objective={self.objective!r}) with solver {name}: status "
                f"{self.problem.status!r}, no answer; {cause}")
        z = (np.asarray(x, dtype=np.float64) - inst.radii) / inst.sigmas
        status = inst.checked_status(z, status, f"formulation:{self.objective}", tol)
        return inst.solution(z, status, f"formulation:{self.objective}", name, t0)

    def __repr__(self) -> str:
        extra = f", huber_delta={self.huber_delta}" if self.objective == "huber" else ""
        return (f"RadialProblem(n={self.n}, objective={self.objective!r}{extra}, "
                f"constraints={1 + len(self._extra)})")


def _as_constraints(out: Any) -> list:
    import cvxpy as cp

    items = list(out) if isinstance(out, (list, tuple)) else [out]
    for c in items:
        if not isinstance(c, cp.constraints.constraint.Constraint):
            raise RadialArgumentError(f"fn must return cvxpy constraints, got {type(c).__name__}")
    return items
