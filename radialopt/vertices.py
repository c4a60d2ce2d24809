"""Vertex enumeration of the restriction polyhedron and projection in V-form (docs/design.md#m6).

A pointed polyhedron ``P = {x : A x <= b}`` is ``conv(V) + cone(R)`` (Minkowski-Weyl): ``V``
its vertices, ``R`` its extreme rays.  The restriction polyhedron of the paper (eq. 16,
section 4.4) is always pointed and has the single ray ``(1, ..., 1) / sqrt(n)``.

Two enumerators, tested against each other and against pycddlib:

* ``"bruteforce"``: every n-subset of rows, batched linear solves, keep feasible points;
  rays from the (n-1)-subsets of the homogeneous system ``A d <= 0``.  Cost ``C(m, n)``.
* ``"double_description"``: the double-description method (Motzkin et al. 1953; Fukuda and
  Prodon 1996) on the homogenised cone ``{(t, x) : t >= 0, t b - A x >= 0}`` with the
  combinatorial adjacency test on zero sets (the adjacency step, on uint64 bitsets, lives in
  ``radialopt._dd_adjacency``).

:func:`project_vform` solves the sigma-weighted projection over ``conv(V) + cone(R)`` with
Wolfe's minimum-norm-point algorithm (1976), and :func:`certify_projection` checks a candidate
projection by the variational inequality over the generators, which is necessary and
sufficient for optimality.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ._checks import MAX_SIGMA, instance, integer, real_array, real_scalar, sigma_range
from ._dd_adjacency import _adjacent_combinations, _unpack_bits
from .errors import (
    RadialArgumentError,
    RadialError,
    SolverError,
)
from .polytope import RestrictionPolytope
from .tolerances import (
    INDEPENDENT_RTOL,
    RANK_RTOL,
    VERTEX_CERTIFICATE_TOL,
    VERTEX_TOLERANCES,
    VFORM_TOL,
    VertexTolerances,
)

__all__ = [
    "ENUMERATION_METHODS",
    "VERTEX_TOLERANCES",
    "MAX_VERTEX_SPHERES",
    "VertexEnumeration",
    "VertexTolerances",
    "certify_projection",
    "check_vertex_spheres",
    "enumerate_vertices",
    "project_vform",
]

#: Names accepted by ``enumerate_vertices(method=...)``.
ENUMERATION_METHODS = ("auto", "bruteforce", "double_description")

#: ``method="auto"`` uses brute force while ``C(m, n)`` is at most this (measured crossover:
#: brute force wins for the n = 3, 4 restriction polytopes, double description from n = 5 on).
AUTO_BRUTEFORCE_MAX_SUBSETS = 4000
#: Largest magnitude of an entry of A or b accepted (normalised rows scale with sigma).
POLYTOPE_MAX = 1e150

#: Largest number of spheres whose restriction polytope (``3 C(n, 2)`` rows in ``n`` dimensions)
#: :func:`enumerate_vertices` accepts: the vertex count grows combinatorially, and 8 spheres
#: take tens of seconds (docs/design.md#defaults).  Beyond it :class:`~radialopt.errors.RadialError`
#: names the count; ``project_radii(..., check=False)`` (the exact active-set projection) or
#: ``method="cvxpy"`` handle any size.  Plain ``(A, b)`` pairs are not limited.
MAX_VERTEX_SPHERES = 7

#: ``method="bruteforce"`` refuses more subsets than this (memory and time).
BRUTEFORCE_MAX_SUBSETS = 1_000_000

#: Brute force caches its A-only work (subset inverses, rays) for at most this many subsets.
_CACHE_MAX_SUBSETS = 200_000


@dataclass(frozen=True)
class VertexEnumeration:
    """Generators of a pointed polyhedron ``{x : A x <= b} = conv(vertices) + cone(rays)``.

    Attributes
    ----------
    vertices : (k, n) float
        The vertices, sorted lexicographically.
    rays : (l, n) float
        The extreme rays, unit norm, sorted lexicographically.
    vertex_active : (k, m) bool
        ``vertex_active[i, j]``: row j of A is tight at vertex i.
    method : str
        ``"bruteforce"`` or ``"double_description"`` (the one that ran).
    """

    vertices: NDArray[np.float64]
    rays: NDArray[np.float64]
    vertex_active: NDArray[np.bool_]
    method: str

    def __post_init__(self) -> None:
        for name, dtype in (("vertices", np.float64), ("rays", np.float64), ("vertex_active", np.bool_)):
            arr = np.array(getattr(self, name), dtype=dtype)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        if self.vertices.ndim != 2 or self.rays.ndim != 2 or self.vertices.shape[1] != self.rays.shape[1]:
            raise RadialArgumentError(
                f"vertices (k, n) and rays (l, n) must agree in n, got {self.vertices.shape} "
                f"and {self.rays.shape}"
            )
        if self.vertex_active.ndim != 2 or self.vertex_active.shape[0] != self.vertices.shape[0]:
            raise RadialArgumentError(
                f"vertex_active must have shape ({self.vertices.shape[0]}, m), got "
                f"{self.vertex_active.shape}"
            )

    @property
    def dim(self) -> int:
        """Dimension n of the space."""
        return int(self.vertices.shape[1])


# ---------------------------------------------------------------------------------------------
# input handling


def _read_inequalities(polytope: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(A, b)`` from a RestrictionPolytope-like object (``.A``, ``.b``) or a pair ``(A, b)``."""
    if isinstance(polytope, (str, bytes)) or polytope is None:
        raise RadialArgumentError(
            f"polytope must be a RestrictionPolytope or a pair (A, b), got {polytope!r:.100}")
    if hasattr(polytope, "A") and hasattr(polytope, "b"):
        A_in, b_in = polytope.A, polytope.b
    elif isinstance(polytope, tuple) and len(polytope) == 2:
        A_in, b_in = polytope
    else:
        raise RadialArgumentError(
            f"polytope must be a RestrictionPolytope or a pair (A (m, n), b (m,)), got "
            f"{type(polytope).__name__}"
        )
    A = real_array("polytope.A", A_in, shape=("m", "n"), max_abs=POLYTOPE_MAX)
    if A.shape[0] < 1 or A.shape[1] < 1:
        raise RadialArgumentError(f"polytope.A must have shape (m, n) with m, n >= 1, got shape {A.shape}")
    b = real_array("polytope.b", b_in, shape=(A.shape[0],), max_abs=POLYTOPE_MAX)
    return A, b


@dataclass(frozen=True)
class _Normalized:
    """Unit-row inequalities ``A x <= b`` scaled by ``scale`` (``x = scale * x_unit``)."""

    A: NDArray[np.float64]  # (m', n) unit rows of the original problem
    b: NDArray[np.float64]  # (m',) matching right-hand sides, original units
    rows: NDArray[np.int64]  # (m',) indices of these rows in the original A
    scale: float
    empty: bool


def _normalize(A: NDArray[np.float64], b: NDArray[np.float64], tol: VertexTolerances) -> _Normalized:
    m, n = A.shape
    norms = np.linalg.norm(A, axis=1)
    keep = norms > 0.0
    # rows 0 . x <= b_i: trivially true (b_i >= 0) or infeasible
    empty = bool(np.any(b[~keep] < 0.0))
    An = A[keep] / norms[keep, None]
    bn = b[keep] / norms[keep]
    if An.shape[0] == 0 or np.linalg.matrix_rank(An) < n:
        raise RadialArgumentError(
            f"the polyhedron {{x : A x <= b}} with A of shape {A.shape} and rank "
            f"{np.linalg.matrix_rank(A) if m else 0} < n = {n} contains a line, so it has no vertices"
        )
    scale = max(1.0, float(np.max(np.abs(bn))))
    return _Normalized(An, bn, np.flatnonzero(keep), scale, empty)


# ---------------------------------------------------------------------------------------------
# public entry point


def enumerate_vertices(
    polytope: Any, method: str = "auto", tol: VertexTolerances = VERTEX_TOLERANCES
) -> VertexEnumeration:
    """Vertices and extreme rays of the pointed polyhedron ``{x : A x <= b}``.

    Parameters
    ----------
    polytope : RestrictionPolytope or tuple (A (m, n), b (m,))
        The inequalities; any object with attributes ``A`` and ``b`` works.
    method : {"auto", "bruteforce", "double_description"}
        ``"auto"`` runs brute force while ``C(m, n) <= AUTO_BRUTEFORCE_MAX_SUBSETS`` (faster
        there by measurement) and double description otherwise.
    tol : VertexTolerances
        Numerical tolerances.

    Returns
    -------
    VertexEnumeration
        ``vertices (k, n)`` sorted lexicographically, unit ``rays (l, n)``,
        ``vertex_active (k, m)``.  An empty polyhedron gives ``k = l = 0``.

    Raises
    ------
    RadialError
        - Bad ``A`` or ``b``.
        - ``rank(A) < n``: the polyhedron contains a line.
        - ``method="bruteforce"`` with more than ``BRUTEFORCE_MAX_SUBSETS`` subsets.
        - A :class:`RestrictionPolytope` of more than :data:`MAX_VERTEX_SPHERES` spheres.
        - ``method`` is not one of ``ENUMERATION_METHODS``.
    """
    if not isinstance(method, str) or method not in ENUMERATION_METHODS:
        raise RadialArgumentError(f"unknown method {method!r:.100}; choose one of {ENUMERATION_METHODS}")
    instance("tol", tol, VertexTolerances)
    A, b = _read_inequalities(polytope)
    m, n = A.shape
    if isinstance(polytope, RestrictionPolytope):
        check_vertex_spheres(n, "polytope")
    norm = _normalize(A, b, tol)
    if method == "auto":
        method = "bruteforce" if math.comb(norm.A.shape[0], n) <= AUTO_BRUTEFORCE_MAX_SUBSETS else (
            "double_description"
        )
    if norm.empty:
        return VertexEnumeration(np.zeros((0, n)), np.zeros((0, n)), np.zeros((0, m), bool), method)
    if method == "bruteforce":
        points, rays, zero_sets = _bruteforce(norm, tol)
    else:
        points, rays, zero_sets = _double_description(norm, tol)
    return _finalize(A, b, norm, points, rays, method, tol, zero_sets)


# ---------------------------------------------------------------------------------------------
# brute force


@lru_cache(maxsize=64)
def check_vertex_spheres(n: int, name: str) -> None:
    """Raise :class:`RadialError` when ``n`` spheres exceed :data:`MAX_VERTEX_SPHERES`."""
    if n > MAX_VERTEX_SPHERES:
        raise RadialArgumentError(
            f"{name} has {n} spheres; vertex enumeration accepts at most MAX_VERTEX_SPHERES = "
            f"{MAX_VERTEX_SPHERES} (its time grows combinatorially: 8 spheres take about 20-35 s); "
            "use project_radii(..., check=False) (exact active-set projection) or method='cvxpy' instead")


def _subsets(m: int, k: int) -> NDArray[np.intp]:
    """All k-subsets of range(m), shape (C(m, k), k), lexicographic.  Read-only, cached."""
    if k == 0:
        out = np.zeros((1, 0), dtype=np.intp)
    else:
        count = math.comb(m, k)
        out = np.fromiter(itertools.chain.from_iterable(itertools.combinations(range(m), k)),
                          dtype=np.intp, count=count * k).reshape(count, k)
    out.setflags(write=False)
    return out


def _bruteforce(
    norm: _Normalized, tol: VertexTolerances
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Vertices (feasible solutions of nonsingular n-subsets), rays, and each vertex's rows
    that hold with equality ``(k, m')``."""
    A, b = norm.A, norm.b / norm.scale  # unit rows, |b| <= 1
    m, n = A.shape
    count = math.comb(m, n)
    if count > BRUTEFORCE_MAX_SUBSETS:
        raise RadialArgumentError(
            f"brute force needs C({m}, {n}) = {count} subsets (> {BRUTEFORCE_MAX_SUBSETS}); "
            "use method='double_description'"
        )
    structure = _bruteforce_structure if count <= _CACHE_MAX_SUBSETS else _bruteforce_structure.__wrapped__
    idx, inverses, rays = structure(A.tobytes(), m, n, tol)
    pts = np.einsum("cij,cj->ci", inverses, b[idx])
    feasible = np.all(pts @ A.T <= b + tol.feasibility, axis=1)
    pts = pts[feasible]
    if pts.shape[0]:
        # one point per set of tight rows: a degenerate vertex comes from many subsets
        tight = np.abs(b - pts @ A.T) <= tol.active
        first = _unique_tight_sets(tight)
        pts, tight = pts[first], tight[first]
    else:
        tight = np.zeros((0, m), dtype=bool)
    return pts * norm.scale, rays, tight


def _unique_tight_sets(tight: NDArray[np.bool_]) -> NDArray[np.intp]:
    """Indices of the first row of every distinct boolean row pattern, in order."""
    packed = np.packbits(tight, axis=1)
    pad = (-packed.shape[1]) % 8
    keys = np.ascontiguousarray(np.pad(packed, ((0, 0), (0, pad)))).view(np.uint64)
    _, first = np.unique(keys, axis=0, return_index=True)
    return np.sort(first)


@lru_cache(maxsize=4)
def _bruteforce_structure(
    A_bytes: bytes, m: int, n: int, tol: VertexTolerances
) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]:
    """The part of brute force that depends on A only (cached: the restriction polytope's A
    depends only on n): nonsingular n-subsets ``(c, n)``, their inverses ``(c, n, n)`` and the
    extreme rays ``(l, n)`` of ``{d : A d <= 0}``."""
    A = np.frombuffer(A_bytes, dtype=np.float64).reshape(m, n)
    idx = _subsets(m, n)
    M = A[idx]  # (C, n, n)
    ok = np.abs(np.linalg.det(M)) > tol.singular
    idx = idx[ok]
    inverses = np.linalg.inv(M[ok])
    rays = _bruteforce_rays(A, tol)
    for arr in (idx, inverses, rays):
        arr.setflags(write=False)
    return idx, inverses, rays


def _bruteforce_rays(A: NDArray[np.float64], tol: VertexTolerances) -> NDArray[np.float64]:
    """Extreme rays of ``{d : A d <= 0}`` from the null vectors of rank-(n-1) row subsets."""
    m, n = A.shape
    if n == 1:
        cand = np.array([[1.0], [-1.0]])
    else:
        idx = _subsets(m, n - 1)
        M = A[idx]  # (C, n-1, n)
        # generalised cross product: d_j = (-1)^j det(M without column j)
        cols = np.arange(n)
        d = np.stack([(-1.0) ** j * np.linalg.det(M[:, :, cols != j]) for j in range(n)], axis=1)
        lengths = np.linalg.norm(d, axis=1)
        d = d[lengths > tol.singular] / lengths[lengths > tol.singular, None]
        cand = np.concatenate([d, -d])
    cand = cand[np.all(cand @ A.T <= tol.feasibility, axis=1)]
    if cand.shape[0]:
        cand = cand[_unique_tight_sets(np.abs(cand @ A.T) <= tol.active)]
    return cand


# ---------------------------------------------------------------------------------------------
# double description


def _initial_basis(H: NDArray[np.float64], tol: float) -> list[int]:
    """Greedy: the first rows of H (in order) that are linearly independent, d of them."""
    d = H.shape[1]
    basis: list[int] = []
    Q = np.zeros((0, d))
    for i, h in enumerate(H):
        r = h - Q.T @ (Q @ h)
        r = r - Q.T @ (Q @ r)  # re-orthogonalise
        nr = np.linalg.norm(r)
        if nr > INDEPENDENT_RTOL:
            basis.append(i)
            Q = np.vstack([Q, r / nr])
            if len(basis) == d:
                break
    return basis


def _double_description(
    norm: _Normalized, tol: VertexTolerances
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Vertices ``(k, n)``, rays ``(l, n)`` and the vertices' zero sets ``(k, m')`` (rows of
    ``norm.A``) from the DD method on ``{y = (t, x) : H y >= 0}``.

    Rows are added in their given order after an initial basis (the first linearly independent
    rows, starting with ``t >= 0``), so the result is deterministic.  Rays are kept unit-norm;
    zero sets are bitsets over the processed rows (packed in uint64 words).
    """
    A, b = norm.A, norm.b / norm.scale
    m, n = A.shape
    d = n + 1
    H = np.zeros((m + 1, d))
    H[0, 0] = 1.0  # t >= 0
    H[1:, 0] = b
    H[1:, 1:] = -A
    H /= np.linalg.norm(H, axis=1)[:, None]
    eps = tol.zero
    basis = _initial_basis(H, eps)
    if len(basis) < d:  # cannot happen after the rank check; keep the error explicit
        raise SolverError(f"homogenised system has rank {len(basis)} < {d}")
    R = np.linalg.inv(H[basis]).T  # rows: extreme rays of the simplicial cone H[basis] y >= 0
    R /= np.linalg.norm(R, axis=1)[:, None]
    words = (m + 1 + 63) // 64
    Z = np.zeros((d, words), dtype=np.uint64)  # zero sets over processed rows
    for i in range(d):
        for j in basis:
            if j != basis[i]:
                Z[i, j // 64] |= np.uint64(1) << np.uint64(j % 64)
    in_basis = np.zeros(m + 1, dtype=bool)
    in_basis[basis] = True
    for j in map(int, np.flatnonzero(~in_basis)):
        s = R @ H[j]
        pos = s > eps
        neg = s < -eps
        zer = ~(pos | neg)
        bit = np.uint64(1) << np.uint64(j % 64)
        if neg.any():
            new_R, new_Z = _adjacent_combinations(R, Z, s, np.flatnonzero(pos), np.flatnonzero(neg), d)
            new_Z[:, j // 64] |= bit
            keep = ~neg
            Z[zer, j // 64] |= bit
            R = np.concatenate([R[keep], new_R])
            Z = np.concatenate([Z[keep], new_Z])
        else:
            Z[zer, j // 64] |= bit
    t = R[:, 0]
    is_vertex = t > eps
    vertices = R[is_vertex, 1:] / t[is_vertex, None] * norm.scale
    zero_sets = _unpack_bits(Z[is_vertex])[:, 1 : m + 1]  # drop the t >= 0 row
    rays = R[~is_vertex, 1:]
    lengths = np.linalg.norm(rays, axis=1)
    rays = rays[lengths > eps] / lengths[lengths > eps, None]
    return vertices, rays, zero_sets


# ---------------------------------------------------------------------------------------------
# shared post-processing


def _finalize(
    A: NDArray[np.float64],
    b: NDArray[np.float64],
    norm: _Normalized,
    points: NDArray[np.float64],
    rays: NDArray[np.float64],
    method: str,
    tol: VertexTolerances,
    zero_sets: NDArray[np.bool_] | None = None,
) -> VertexEnumeration:
    """Polish, merge, sort; compute the tight rows of every vertex in the original ``A``.

    ``zero_sets (k, m')``: the rows of ``norm.A`` that define each vertex combinatorially
    (double description); without them the rows tight within ``tol.active`` are used.
    """
    m, n = A.shape
    An, bn, scale = norm.A, norm.b, norm.scale
    if points.shape[0] == 0:  # a pointed nonempty polyhedron has a vertex: this one is empty
        return VertexEnumeration(np.zeros((0, n)), np.zeros((0, n)), np.zeros((0, m), bool), method)
    if zero_sets is None:
        zero_sets = np.abs(bn - points @ An.T) <= tol.active * scale
    points = _polish_vertices(An, bn, points, zero_sets)
    points = points[_merge_representatives(points, tol.merge * scale)]
    points = points[np.lexsort(points.T[::-1])]
    if rays.shape[0]:
        rays = _polish_rays(An, rays, tol.active)
        rays = rays[_merge_representatives(rays, tol.merge)]
        rays = rays[np.lexsort(rays.T[::-1])]
    norms = np.linalg.norm(A, axis=1)
    slack = (b[None, :] - points @ A.T) / np.where(norms > 0, norms, 1.0)
    active = (np.abs(slack) <= tol.active * scale) & (norms > 0)
    return VertexEnumeration(points, rays, active, method)


def _polish_vertices(
    A: NDArray[np.float64], b: NDArray[np.float64], points: NDArray[np.float64], rows: NDArray[np.bool_]
) -> NDArray[np.float64]:
    """One least-squares solve per vertex on its defining rows ``rows (k, m)`` (batched normal
    equations; vertices whose rows do not have full rank are left as they are)."""
    tight = rows.astype(np.float64)  # (k, m)
    G = np.einsum("km,mi,mj->kij", tight, A, A)
    rhs = (tight * b) @ A
    # unit rows: det(G) <= |T|^n, and it is ~0 when the rows do not have rank n
    good = np.abs(np.linalg.det(G)) > RANK_RTOL
    out = points.copy()
    if np.any(good):
        out[good] = np.linalg.solve(G[good], rhs[good][..., None])[..., 0]
    return out


def _polish_rays(A: NDArray[np.float64], rays: NDArray[np.float64], atol: float) -> NDArray[np.float64]:
    """Replace each ray by the null vector of its tight rows (sign kept), unit length."""
    out = rays.copy()
    for i, r in enumerate(rays):
        tight = np.abs(A @ r) <= atol
        if np.count_nonzero(tight) >= A.shape[1] - 1:
            _, sv, vt = np.linalg.svd(A[tight])
            if sv.size >= A.shape[1] - 1 and (A.shape[1] == 1 or sv[A.shape[1] - 2] > INDEPENDENT_RTOL):
                v = vt[-1]
                out[i] = v if v @ r > 0 else -v
    return out / np.linalg.norm(out, axis=1)[:, None]


def _merge_representatives(points: NDArray[np.float64], radius: float) -> NDArray[np.intp]:
    """Indices of one point per cluster of points closer than ``radius`` (chained)."""
    k = points.shape[0]
    if k < 2:
        return np.arange(k)
    pairs = cKDTree(points).query_pairs(radius, output_type="ndarray")
    if pairs.shape[0] == 0:
        return np.arange(k)
    graph = coo_matrix((np.ones(pairs.shape[0]), (pairs[:, 0], pairs[:, 1])), shape=(k, k))
    _, labels = connected_components(graph, directed=False)
    _, first = np.unique(labels, return_index=True)
    return np.sort(first)


# ---------------------------------------------------------------------------------------------
# projection in V-form


def _check_target(enumeration: VertexEnumeration, target: ArrayLike, sigmas: ArrayLike
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    if not isinstance(enumeration, VertexEnumeration):
        raise RadialArgumentError(
            f"enumeration must be a VertexEnumeration, got {type(enumeration).__name__}")
    n = enumeration.dim
    t = real_array("target", target, shape=(n,))
    s = real_array("sigmas", sigmas, shape=(n,), max_abs=MAX_SIGMA)
    scale = max(float(np.abs(t).max(initial=0.0)), float(np.abs(enumeration.vertices).max(initial=0.0)))
    sigma_range("sigmas", s, scale)
    if enumeration.vertices.shape[0] == 0:
        raise RadialArgumentError("the polyhedron is empty: there is nothing to project onto")
    return t, s


def project_vform(
    enumeration: VertexEnumeration,
    target: ArrayLike,
    sigmas: ArrayLike,
    tol: float = VFORM_TOL,
    max_iter: int = 1000,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Sigma-weighted projection of ``target`` onto ``conv(vertices) + cone(rays)``.

    Minimises ``sum(((x - target) / sigmas)**2)`` over ``x = V^T lam + R^T mu``, ``lam >= 0``,
    ``sum(lam) = 1``, ``mu >= 0`` (docs/design.md#m6) with Wolfe's minimum-norm-point algorithm
    (1976) in whitened coordinates: points ``w_k = (v_k - target) / sigmas``, directions
    ``d_l / sigmas`` whose weights are ``>= 0`` and outside the simplex sum.  Each minor cycle
    solves the affine minimisation on the current support exactly (a small KKT system).

    Parameters
    ----------
    enumeration : VertexEnumeration
        Generators ``vertices (k, n)`` and ``rays (l, n)``.
    target : (n,) float
        The point to project (e.g. measured radii).
    sigmas : (n,) float
        Positive weights (standard deviations), same space as ``target``.
    tol : float
        Optimality tolerance of the major cycle, relative to ``|z| max|w|`` (the rounding
        scale of the whitened inner products); also the weight below which a generator
        leaves the support.
    max_iter : int
        Limit on major plus minor cycles.

    Returns
    -------
    point : (n,) float
        The projection.
    weights : (k + l,) float
        ``lam`` for the k vertices followed by ``mu`` for the l rays:
        ``point = vertices.T @ lam + rays.T @ mu``.

    Raises
    ------
    SolverError
        No convergence within ``max_iter`` cycles.
    """
    t, s = _check_target(enumeration, target, sigmas)
    tol = real_scalar("tol", tol, minimum=0.0, maximum=1.0)
    max_iter = integer("max_iter", max_iter, minimum=1, maximum=10**7)
    V, R = enumeration.vertices, enumeration.rays
    k, n = V.shape
    W = (V - t) / s
    D = R / s
    dlen = np.linalg.norm(D, axis=1)
    D = D / dlen[:, None] if D.shape[0] else D
    gens = np.concatenate([W, D])  # (k + l, n)
    is_point = np.arange(gens.shape[0]) < k
    max_len = max(1.0, float(np.sqrt(np.max(np.sum(W * W, axis=1)))))
    support = [int(np.argmin(np.sum(W * W, axis=1)))]
    weights = np.array([1.0])
    x = gens[support[0]].copy()
    iters = 0
    while True:
        iters += 1
        if iters > max_iter:
            raise SolverError(f"project_vform: no convergence in {max_iter} cycles (n = {n}, k = {k})")
        gx = gens @ x
        xx = float(x @ x)
        gap = np.where(is_point, gx - xx, gx)  # >= 0 at the optimum
        j = int(np.argmin(gap))
        # optimal when no generator lies below the supporting hyperplane of |z| at x; the
        # threshold is relative to |x| max|w|, the rounding scale of x . w
        if gap[j] >= -tol * max(1.0, np.sqrt(xx)) * max_len or j in support:
            break
        old = (list(support), weights.copy(), x.copy())
        support.append(j)
        weights = np.append(weights, 0.0)
        while True:  # minor cycle
            iters += 1
            if iters > max_iter:
                raise SolverError(f"project_vform: no convergence in {max_iter} cycles (n = {n}, k = {k})")
            new = _affine_minimizer(gens[support], is_point[support])
            if np.all(new > 0.0):
                weights = new
                break
            down = new <= 0.0
            theta = float(np.min(weights[down] / (weights[down] - new[down])))
            theta = min(max(theta, 0.0), 1.0)
            weights = (1.0 - theta) * weights + theta * new
            keep = weights > tol
            # always drop at least one element (the one that reached zero first)
            if np.all(keep):
                keep[int(np.argmin(np.where(down, weights, np.inf)))] = False
            support = [i for i, kp in zip(support, keep, strict=True) if kp]
            weights = weights[keep]
            pts = is_point[support]
            weights[pts] /= weights[pts].sum()
        x = weights @ gens[support]
        # Wolfe's iterates strictly decrease |x|; the decrease is quadratic in the step, so
        # test it directly and stop when rounding makes it fail (keep the better iterate)
        if float(x @ x) > xx or np.array_equal(x, old[2]):
            support, weights, x = old
            break
    # final exact solve on the support
    final = _affine_minimizer(gens[support], is_point[support])
    if np.all(final >= 0.0):
        weights = final
    full = np.zeros(gens.shape[0])
    full[support] = weights
    full[k:] /= dlen  # back to the rays of the enumeration
    lam, mu = full[:k], full[k:]
    point = V.T @ lam + R.T @ mu
    return point, full


def _affine_minimizer(G: NDArray[np.float64], is_point: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Weights w minimising ``|G^T w|`` subject to ``sum(w[is_point]) = 1`` (w free).

    With ``g0`` the first point of the support, ``G^T w = g0 + M c`` where M holds the
    differences ``g_i - g0`` (points) and the directions (rays); ``c`` comes from a least-squares
    solve on M (no normal equations; rank-deficient supports get the minimum-norm ``c``).
    """
    first = int(np.flatnonzero(is_point)[0])
    g0 = G[first]
    others = np.delete(np.arange(G.shape[0]), first)
    if others.size == 0:
        return np.ones(1)
    M = (G[others] - np.where(is_point[others, None], g0, 0.0)).T  # (n, s - 1)
    c = np.linalg.lstsq(M, -g0, rcond=None)[0]
    w = np.empty(G.shape[0])
    w[others] = c
    w[first] = 1.0 - c[is_point[others]].sum()
    return w


def certify_projection(
    enumeration: VertexEnumeration,
    polytope: Any,
    target: ArrayLike,
    sigmas: ArrayLike,
    point: ArrayLike,
    tol: float = VERTEX_CERTIFICATE_TOL,
) -> tuple[bool, float, str]:
    """Exact optimality certificate of a projection, checked on the generators.

    ``x*`` is the sigma-weighted projection of ``target`` onto ``P = conv(V) + cone(R)`` iff
    ``x*`` is in P and, with ``g = (x* - target) / sigmas**2``, ``g . (v - x*) >= 0`` for every
    vertex v and ``g . d >= 0`` for every ray d (the variational inequality of the convex
    objective, which suffices because every point of P is a combination of generators).

    Parameters
    ----------
    enumeration : VertexEnumeration
        Generators of the polyhedron of ``polytope``.
    polytope : RestrictionPolytope or tuple (A (m, n), b (m,))
        The H-form of the same polyhedron (same space as ``target`` and ``point``).
    target, sigmas, point : (n,) float
        The projected point, its weights, and the candidate answer.
    tol : float
        Accepted violation: ``A x* <= b + tol`` (units of b) and, in whitened units,
        ``z . (w - z) >= -tol * max(1, |z|) * max(1, |w - z|)`` for ``z = (x* - target) / sigmas``
        and every whitened generator w (rays: ``z . d >= -tol * max(1, |z|)``).

    Returns
    -------
    ok : bool
        Whether both conditions hold within ``tol``.
    residual : float
        The larger of the worst feasibility violation and the worst relative
        variational-inequality violation (0 when exact).
    message : str
        ``"ok"`` or which condition failed, naming the row or generator.
    """
    t, s = _check_target(enumeration, target, sigmas)
    A, b = _read_inequalities(polytope)
    n = enumeration.dim
    if A.shape[1] != n:
        raise RadialArgumentError(f"polytope has dimension {A.shape[1]}, enumeration has {n}")
    x = real_array("point", point, shape=(n,))
    tol = real_scalar("tol", tol, minimum=0.0, maximum=1.0)
    row_norm = np.linalg.norm(A, axis=1)
    viol = (A @ x - b) / np.where(row_norm > 0, row_norm, 1.0)
    feas = float(max(0.0, viol.max()))
    z = (x - t) / s
    zn = max(1.0, float(np.linalg.norm(z)))
    W = (enumeration.vertices - t) / s
    diff = W - z
    vi = -(diff @ z) / (zn * np.maximum(1.0, np.linalg.norm(diff, axis=1)))
    worst_v = int(np.argmax(vi))
    opt_v = float(max(0.0, vi[worst_v]))
    opt_r, worst_r = 0.0, -1
    if enumeration.rays.shape[0]:
        D = enumeration.rays / s
        D = D / np.linalg.norm(D, axis=1)[:, None]
        vr = -(D @ z) / zn
        worst_r = int(np.argmax(vr))
        opt_r = float(max(0.0, vr[worst_r]))
    residual = max(feas, opt_v, opt_r)
    if feas > tol:
        k = int(np.argmax(viol))
        return False, residual, f"infeasible: row {k} violated by {feas:.3g} (> tol {tol:g})"
    if opt_v > tol:
        return False, residual, (
            f"not optimal: moving towards vertex {worst_v} {enumeration.vertices[worst_v].tolist()} "
            f"decreases the objective (relative violation {opt_v:.3g} > tol {tol:g})"
        )
    if opt_r > tol:
        return False, residual, (
            f"not optimal: moving along ray {worst_r} decreases the objective "
            f"(relative violation {opt_r:.3g} > tol {tol:g})"
        )
    return True, residual, "ok"


def __getattr__(name: str) -> type[RadialError]:
    """0.1 exported ``EmptyPolyhedronError``, ``NotPointedError`` and ``TooLargeError`` here:
    deprecated names of :class:`~radialopt.errors.RadialArgumentError` (with a warning)."""
    from . import errors

    return errors._deprecated(__name__, name, dict.fromkeys(
        ("EmptyPolyhedronError", "NotPointedError", "TooLargeError"), RadialArgumentError))
