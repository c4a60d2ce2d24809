"""Exact rational arithmetic for ``check="exact"`` of :mod:`radialopt.projection`.

pycddlib's GMP mode enumerates the vertices and rays exactly (``_exact_generators``); the
sigma-weighted projection onto the affine hull of the tight rows is solved in Fractions
(``_exact_kkt_point``).  :func:`~radialopt.projection.verify_solution_exact` uses them.
"""

from __future__ import annotations

from fractions import Fraction

from .errors import RadialArgumentError, VerificationError


def _cdd_gmp():  # noqa: ANN202 - returns (cdd, cdd.gmp)
    """The pycddlib modules ``(cdd, cdd.gmp)``, or a clear error when the GMP mode is missing."""
    try:
        import cdd
        import cdd.gmp as gmp
    except ImportError as exc:
        raise RadialArgumentError(
            "check='exact' needs pycddlib's exact rational mode (the module cdd.gmp), which is "
            "not installed here; install a pycddlib built with GMP (e.g. `pip install pycddlib` "
            "with libcdd and libgmp present), or use check=True (float vertex check)"
        ) from exc
    return cdd, gmp


def _exact_generators(A: list[list[Fraction]], b: list[Fraction]) -> tuple[list, list]:
    """Vertices and rays of ``{x : A x <= b}`` in exact rational arithmetic (pycddlib GMP)."""
    cdd, gmp = _cdd_gmp()
    rows = [[bi] + [-a for a in row] for row, bi in zip(A, b, strict=True)]
    mat = gmp.matrix_from_array(rows, rep_type=cdd.RepType.INEQUALITY)
    gen = gmp.copy_generators(gmp.polyhedron_from_matrix(mat))
    if gen.lin_set:
        raise VerificationError("exact enumeration: the polyhedron contains a line")
    vertices, rays = [], []
    for row in gen.array:
        head = Fraction(row[0])
        if head != 0:
            vertices.append([Fraction(v) / head for v in row[1:]])
        else:
            rays.append([Fraction(v) for v in row[1:]])
    return vertices, rays


def _independent_rows(rows: list[list[Fraction]]) -> list[int]:
    """Indices of a maximal linearly independent subset of ``rows`` (exact elimination)."""
    basis: list[tuple[int, list[Fraction]]] = []  # (pivot column, reduced row)
    keep = []
    for i, row in enumerate(rows):
        v = list(row)
        for col, brow in basis:
            if v[col] != 0:
                f = v[col] / brow[col]
                v = [a - f * c for a, c in zip(v, brow, strict=True)]
        piv = next((j for j, a in enumerate(v) if a != 0), None)
        if piv is not None:
            basis.append((piv, v))
            keep.append(i)
    return keep


def _solve_rational(M: list[list[Fraction]], rhs: list[Fraction]) -> list[Fraction] | None:
    """Gauss-Jordan elimination in Fractions; None when M is singular."""
    k = len(rhs)
    aug = [list(M[i]) + [rhs[i]] for i in range(k)]
    for c in range(k):
        p = next((r for r in range(c, k) if aug[r][c] != 0), None)
        if p is None:
            return None
        aug[c], aug[p] = aug[p], aug[c]
        piv = aug[c][c]
        aug[c] = [a / piv for a in aug[c]]
        for r in range(k):
            if r != c and aug[r][c] != 0:
                f = aug[r][c]
                aug[r] = [a - f * bb for a, bb in zip(aug[r], aug[c], strict=True)]
    return [aug[i][k] for i in range(k)]


def _exact_kkt_point(
    A: list[list[Fraction]], b: list[Fraction], r: list[Fraction], s2: list[Fraction],
    active: list[int],
) -> list[Fraction] | None:
    """The sigma-weighted projection of r onto the affine set ``A_S x = b_S`` (exact)."""
    n = len(r)
    S = [active[i] for i in _independent_rows([A[j] for j in active])]
    if not S:
        return list(r)
    AS = [A[j] for j in S]
    M = [[sum((AS[i][t] * s2[t] * AS[j][t] for t in range(n)), Fraction(0)) for j in range(len(S))]
         for i in range(len(S))]
    rhs = [b[j] - sum((A[j][t] * r[t] for t in range(n)), Fraction(0)) for j in S]
    y = _solve_rational(M, rhs)
    if y is None:
        return None
    return [r[t] + s2[t] * sum(AS[i][t] * y[i] for i in range(len(S))) for t in range(n)]
