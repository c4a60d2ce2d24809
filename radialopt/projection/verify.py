"""The checks of ``check=True`` and ``check="exact"``: a projection's answer against explicit
vertex enumeration, in floating point (:func:`verify_solution`) or in exact rational arithmetic
(:func:`verify_solution_exact`)."""

from __future__ import annotations

from collections.abc import Sequence
from fractions import Fraction

import numpy as np

from .._exact_check import _exact_generators, _exact_kkt_point
from .._projection_types import RadialSolution, _Problem
from ..errors import VerificationError
from ..spheres import TOLERANCES, GaussianSphere, Tolerances

__all__ = ["verify_solution", "verify_solution_exact"]


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
    from ..vertices import certify_projection, enumerate_vertices, project_vform

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
