"""Data association: percepts (ego frame) to world-model objects (paper 2.2, docs/design.md#association).

Two methods share :func:`associate`:

``"clique"`` (default, beyond the paper)
    A typed consistency graph: a vertex is a pair (percept p, model object o) of one type; an
    edge joins (p, o) and (q, u), p != q, o != u, when the percept distance and the model
    distance agree, ``| |x_p - x_q| - |X_o - X_u| | < tau_pq`` (with ``gravity_aligned`` the
    horizontal distance and the height difference are compared separately).  Candidate model
    pairs come from the world's link look-up table (:meth:`WorldModel.link_lengths`), never
    from all pairs.  The graph is k-partite by percept, so an exact branch and bound over the
    percepts with Python-integer bitsets finds the maximum cliques and every maximal clique
    one smaller (false percepts make a wrong clique one larger than the true one possible).
    Cliques of four or more members whose percept and model tetrahedra have opposite signed
    volumes (mirror matches) are rejected.  Every surviving clique becomes a hypothesis:
    weighted Kabsch on its members, then a robust fit cost, the capped squared normalised
    residual of *every* percept against its nearest same-type model object under that pose,
    which also validates the hypothesis with the percepts not used to build it.
``"paper"``
    The paper's filters: proximity filtering (eq. 1, the intersection of the link sets of all
    percept pairs) and orientation filtering (eqs. 2-3, signature vectors of percept triples
    in the eq.-5 frame), then the complete assignments of the surviving links.  No percept
    may be false: one false percept empties the intersection.

Note on eqs. 2-3: the signature ``V = R^T (x_j - x_k)`` in the frame of the triple is a
function of the triangle's side lengths only (the third point always has a negative third
coordinate in that frame), so the orientation filter accepts nothing that the pairwise
distances reject; it is kept as the paper states it.  The signed volume used by the clique
method is what rejects mirror matches.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any

import networkx as nx
import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from perception import Percept

from ._checks import as_list, finite_float, float_array, positive_float, rigid_transform, strict_int
from .errors import (
    ArgumentTypeError,
    EmptyWorldError,
    NonPositiveError,
    OutOfRangeError,
    ShapeError,
    TooFewPerceptsError,
    UnknownTypeError,
    WorldGraphError,
)
from .model import FAR_PAIR_HEIGHT, FAR_PAIR_RANGE, FAR_PAIR_SLACK, FarPairIndex, WorldModel
from .pose import invert_transformation, weighted_kabsch_batch

__all__ = [
    "ASSOCIATION_METHODS",
    "ASSOCIATION_TOLERANCES",
    "AssociationHypothesis",
    "AssociationTolerances",
    "CliqueSearch",
    "associate",
    "consistency_graph",
    "filtered_graph_view",
    "discriminator",
    "is_ambiguous",
    "maximum_cliques",
    "same_pose",
    "orientation_filter",
    "proximity_filter",
]

ASSOCIATION_METHODS = ("clique", "paper")


@dataclass(frozen=True)
class AssociationTolerances:
    """Tolerances of the association, in one frozen place.

    Attributes
    ----------
    n_sigma : float
        Gate width in standard deviations.
    pair_factor : float
        Extra factor on the pair gate, ``tau_pq = n_sigma * pair_factor * sqrt(s_p^2 + s_q^2)
        + min_tolerance``; sqrt(2) keeps a true pair inside the gate with probability
        ~1 - 2e-5 at 3 sigma, so that all ~45 pairs of ten percepts pass together.
    min_tolerance : float
        Floor (metres) added to every distance gate (model inaccuracy).
    kappa_max : float
        Orientation filter, eq. 3: maximal angle (rad) between signature vectors.
    mu_max : float or None
        Orientation filter, eq. 2: maximal length (m) of the signature difference; ``None``
        derives it per triple like ``tau`` from the three sigmas.
    gravity_aligned : bool or None
        The ego z axis is the world z axis (REP 103 ego with a levelled base): compare the
        horizontal distance and the height difference of pairs separately, so pairs across
        storeys drop out.  ``None`` (default) follows the world's
        :attr:`~worldgraph.model.WorldModel.gravity_aligned` (the building and campus scenes set
        it; the kitchen and ``from_*`` worlds do not unless asked).
    height_tolerance : float or None
        Gate (m) of the height difference when ``gravity_aligned``; ``None`` uses ``tau``.
    cost_cap : float
        Cap of a percept's squared normalised residual in the robust fit cost.
    residual_factor : float
        The residual of a percept under a fitted pose is normalised by ``residual_factor *
        sigma`` (the pose itself is uncertain).
    min_clique_size : int
        Smallest clique that makes a hypothesis (three points fix a pose).
    near_maximum : int
        Maximal cliques down to ``maximum size - near_maximum`` are kept.
    ambiguity_margin : float
        The best two (pose-distinct) hypotheses are ambiguous when their robust costs differ by
        less.  A cost difference is twice a log-likelihood ratio: the default 6 calls a runner-up
        ambiguous unless the best is 20 times as likely (at 4, chance fits of repeated cabinet
        modules were answered "ok" and wrong in our layouts).
    distinct_translation, distinct_angle : float
        Two hypotheses with translations closer than this (m) and rotations closer than this
        (rad) are the same pose: only the cheaper one is kept.
    chirality_sigmas : float
        A tetrahedron's signed volume decides chirality only when both volumes exceed this
        many standard deviations of the percept volume.
    max_nodes : int
        Node budget of one branch-and-bound search (the result says when it ran out).
    max_cliques : int
        At most this many cliques (largest first) are fitted and ranked.
    dense_pair_limit : int
        Percept pairs farther apart than the link table covers are matched by brute force when
        the two types have at most this many object pairs, otherwise by a k-d tree ball query.
    max_hypotheses : int
        Default number of hypotheses returned by :func:`associate`.
    max_search_percepts : int
        The clique search (and the paper's filters) use at most this many percepts, the most
        certain ones (smallest sigma); the others are validated against each hypothesis' pose
        and enter its cost (the paper generates candidates from at most 6 spheres and
        validates with the rest).
    """

    n_sigma: float = 3.0
    pair_factor: float = math.sqrt(2.0)
    min_tolerance: float = 0.01
    kappa_max: float = math.radians(20.0)
    mu_max: float | None = None
    gravity_aligned: bool | None = None
    height_tolerance: float | None = None
    cost_cap: float = 9.0
    residual_factor: float = math.sqrt(2.0)
    min_clique_size: int = 3
    near_maximum: int = 1
    ambiguity_margin: float = 6.0
    distinct_translation: float = 0.25
    distinct_angle: float = math.radians(5.0)
    chirality_sigmas: float = 3.0
    max_nodes: int = 50_000
    max_cliques: int = 2000
    dense_pair_limit: int = 250_000
    max_hypotheses: int = 16
    max_search_percepts: int = 10

    def __post_init__(self) -> None:
        def put(name: str, value: object) -> None:
            object.__setattr__(self, name, value)

        for name in ("n_sigma", "pair_factor", "cost_cap", "residual_factor", "distinct_translation"):
            put(name, positive_float(f"AssociationTolerances.{name}", getattr(self, name), maximum=1e12))
        for name in ("min_tolerance", "ambiguity_margin", "chirality_sigmas"):
            put(name, positive_float(f"AssociationTolerances.{name}", getattr(self, name), allow_zero=True,
                                     maximum=1e12))
        for name in ("kappa_max", "distinct_angle"):
            v = positive_float(f"AssociationTolerances.{name}", getattr(self, name))
            if v > math.pi:
                raise OutOfRangeError(f"AssociationTolerances.{name} = {v!r} is an angle in radians and must "
                                      f"be <= pi; degrees? use np.radians({v!r}) = {math.radians(v):.6g}")
            put(name, v)
        for name in ("mu_max", "height_tolerance"):
            v = getattr(self, name)
            if v is not None:
                put(name, positive_float(f"AssociationTolerances.{name}", v, maximum=1e12))
        if self.gravity_aligned is not None:
            if not isinstance(self.gravity_aligned, bool | np.bool_):
                raise ArgumentTypeError(f"AssociationTolerances.gravity_aligned must be a bool or None, "
                                        f"got {self.gravity_aligned!r}")
            put("gravity_aligned", bool(self.gravity_aligned))
        put("min_clique_size", strict_int("AssociationTolerances.min_clique_size", self.min_clique_size,
                                          minimum=2, maximum=64))
        put("max_search_percepts", strict_int("AssociationTolerances.max_search_percepts",
                                              self.max_search_percepts, minimum=2, maximum=100_000))
        if self.min_clique_size > self.max_search_percepts:
            raise OutOfRangeError(f"AssociationTolerances.min_clique_size = {self.min_clique_size} exceeds "
                                  f"max_search_percepts = {self.max_search_percepts} (the clique search "
                                  "looks at that many percepts at most): raise max_search_percepts too")
        for name, lo in (("near_maximum", 0), ("max_nodes", 1), ("max_cliques", 1), ("dense_pair_limit", 0),
                         ("max_hypotheses", 1)):
            put(name, strict_int(f"AssociationTolerances.{name}", getattr(self, name), minimum=lo,
                                 maximum=10**9))

    def pair_tolerance(self, sigma_p: float | NDArray, sigma_q: float | NDArray) -> float | NDArray:
        """``tau_pq = n_sigma * pair_factor * sqrt(s_p^2 + s_q^2) + min_tolerance`` (metres);
        sigmas are non-negative finite reals (scalars or arrays that broadcast)."""
        sp = float_array("sigma_p", sigma_p, None, max_abs=1e150)
        sq = float_array("sigma_q", sigma_q, None, max_abs=1e150)
        for name, arr in (("sigma_p", sp), ("sigma_q", sq)):
            if np.any(arr < 0):
                i = int(np.flatnonzero(np.ravel(arr) < 0)[0])
                raise NonPositiveError(f"{name}[{i}] must be >= 0, got {float(np.ravel(arr)[i])!r}"
                                       if arr.ndim else f"{name} must be >= 0, got {float(arr)!r}")
        try:
            out = self.n_sigma * self.pair_factor * np.hypot(sp, sq) + self.min_tolerance
        except ValueError as exc:
            raise ShapeError(f"sigma_p {sp.shape} and sigma_q {sq.shape} do not broadcast") from exc
        return float(out) if np.ndim(out) == 0 else out


ASSOCIATION_TOLERANCES = AssociationTolerances()


@dataclass(frozen=True)
class AssociationHypothesis:
    """One association of percepts to model objects, with the pose it implies.

    Attributes
    ----------
    pairs : tuple of (percept_index, object_index)
        The clique (or the paper's complete assignment), sorted by percept index.
    cost : float
        Robust fit cost: ``sum_p min(|R x_p + t - X_nearest(p)|^2 / (residual_factor
        sigma_p)^2, cost_cap)`` over all percepts, nearest among the objects of p's type.
    size : int
        ``len(pairs)``.
    world_from_ego : (4, 4) float
        Weighted Kabsch pose of the pairs.
    validated : tuple of (percept_index, object_index)
        Percepts outside the clique whose nearest same-type object under the pose lies inside
        the gate (hypothesis validation with percepts not used to build it).
    inliers : int
        Percepts (clique or validated) whose residual is inside the gate.
    complete : bool
        False when the clique search hit ``max_nodes`` or ``max_cliques``: other hypotheses
        of the same size may exist (a highly repetitive world); treat as ambiguous.
    radial : radialopt.RadialSolution or None
        Filled by :func:`~worldgraph.localize`: the projection of the hypothesis' Gaussian
        spheres (centre = model object, radius = percept range, sigma) onto their restriction
        polytope, the paper's range-consistency score (its ``normalized_displacement``).
    """

    pairs: tuple[tuple[int, int], ...]
    cost: float
    size: int
    world_from_ego: NDArray[np.float64] = field(default_factory=lambda: np.eye(4))
    validated: tuple[tuple[int, int], ...] = ()
    inliers: int = 0
    complete: bool = True
    radial: Any = None

    @property
    def all_pairs(self) -> tuple[tuple[int, int], ...]:
        """``pairs`` and ``validated`` merged, sorted by percept index."""
        return tuple(sorted(self.pairs + self.validated))


@dataclass(frozen=True)
class CliqueSearch:
    """Result of :func:`maximum_cliques`.

    Attributes
    ----------
    cliques : list of tuple of (part, vertex)
        Maximal cliques of size ``>= max(maximum - near_maximum, min_size)``, as (part index,
        vertex index within the part) sorted by part; largest first.
    maximum : int
        Size of the maximum clique (0 when none reaches ``min_size``).
    complete : bool
        False when the node budget ran out (the answer may then miss cliques).
    nodes : int
        Branch-and-bound nodes visited.
    """

    cliques: list[tuple[tuple[int, int], ...]]
    maximum: int
    complete: bool
    nodes: int


# ----------------------------------------------------------------------------------------------
# exact maximum cliques of a k-partite graph (bitsets)
# ----------------------------------------------------------------------------------------------
def _bits(indices: NDArray[np.intp] | Sequence[int]) -> int:
    out = 0
    for b in indices:
        out |= 1 << int(b)
    return out


#: Sparse adjacency between two parts of at most this many vertex pairs is packed into bit rows
#: up front (8 MiB at most); larger ones keep CSR rows, turned into bitsets per visited vertex.
DENSE_BITS = 1 << 26


def _csr(key: tuple[int, int], pairs: tuple, sizes: list[int], forward: bool
         ) -> tuple[NDArray[np.intp], NDArray[np.intp], int] | NDArray[np.uint8] | int:
    """Sparse adjacency ``(rows, cols)`` of parts ``key = (p, q)`` as rows of p's vertices
    (``forward``) or of q's: packed bit rows when small (:data:`DENSE_BITS`), else CSR
    ``(indptr, cols, size of the other part)``; 0 without edges."""
    if len(pairs) != 2:
        raise ShapeError(f"adjacency[{key}] must be a bool matrix or a pair (rows, cols) of index "
                         f"arrays, got a tuple of length {len(pairs)}")
    p, q = key
    rows, cols = (np.asarray(x) for x in pairs)
    for name, arr, size in (("rows", rows, sizes[p]), ("cols", cols, sizes[q])):
        if arr.ndim != 1 or (arr.size and arr.dtype.kind not in "iu"):
            raise ArgumentTypeError(f"adjacency[{key}] {name} must be a 1-D integer array, got dtype "
                                    f"{arr.dtype} and shape {arr.shape}")
        if arr.size and (arr.min() < 0 or arr.max() >= size):
            bad = int(np.flatnonzero((arr < 0) | (arr >= size))[0])
            raise OutOfRangeError(f"adjacency[{key}] {name}[{bad}] = {int(arr[bad])} is outside "
                                  f"[0, {size})")
    if rows.shape != cols.shape:
        raise ShapeError(f"adjacency[{key}] rows and cols must have equal length, got {rows.shape} "
                         f"and {cols.shape}")
    if rows.size == 0:
        return 0
    src, dst, n_src, n_dst = (rows, cols, sizes[p], sizes[q]) if forward else (cols, rows, sizes[q], sizes[p])
    if n_src * n_dst <= DENSE_BITS:  # small: packed bit rows, cheaper per visited vertex
        mat = np.zeros((n_src, n_dst), dtype=bool)
        mat[src, dst] = True
        return np.packbits(mat, axis=1, bitorder="little")
    order = np.argsort(src, kind="stable")
    indptr = np.searchsorted(src[order], np.arange(n_src + 1)).astype(np.intp)
    return indptr, dst[order].astype(np.intp), n_dst


def maximum_cliques(
    sizes: Sequence[int],
    adjacency: Mapping[tuple[int, int],
                       NDArray[np.bool_] | tuple[NDArray[np.integer], NDArray[np.integer]] | None],
    min_size: int = 1,
    near_maximum: int = 0,
    max_nodes: int = 1_000_000,
    allowed: Sequence[NDArray[np.bool_]] | None = None,
    max_cliques: int | None = None,
    stop_at: int | None = None,
) -> CliqueSearch:
    """Exact maximum (and near-maximum maximal) cliques of a k-partite graph.

    Parts are the percepts; part p has ``sizes[p]`` vertices.  No edge joins two vertices of
    one part, so a clique holds at most one vertex per part.  The branch and bound visits the
    parts in order of increasing candidate count; at each part it tries every vertex
    compatible with the chosen ones (an AND of Python-int bitsets), then skipping the part,
    and prunes when the chosen count plus the number of later parts with a compatible vertex
    cannot reach the threshold ``max(best - near_maximum, min_size)``.

    Parameters
    ----------
    sizes : (k,) int
    adjacency : dict (p, q) -> (sizes[p], sizes[q]) bool, (rows, cols) int arrays, or None
        For ``p < q``: a boolean matrix, or the compatible pairs as two equal-length integer
        arrays (vertex ``rows[i]`` of part p with vertex ``cols[i]`` of part q; sparse, memory
        linear in the edges); ``None`` means every pair is compatible; a missing key means none
        is.
    min_size : int
    near_maximum : int
        Also return maximal cliques down to ``maximum - near_maximum``.
    max_nodes : int
    allowed : sequence of (sizes[p],) bool, optional
        Vertices that may be used (default all).
    max_cliques : int, optional
        Stop (``complete=False``) once this many cliques are recorded.
    stop_at : int, optional
        Stop (``complete=True``) at the first clique of at least this size, for a caller that
        knows no larger clique exists.

    Returns
    -------
    CliqueSearch
    """
    if sizes is None or isinstance(sizes, str | bytes):
        raise ArgumentTypeError(f"sizes must be a sequence of non-negative integers, got {sizes!r}")
    sizes = [strict_int(f"sizes[{i}]", s, minimum=0, maximum=10**7) for i, s in enumerate(sizes)]
    if not isinstance(adjacency, dict):
        raise ArgumentTypeError(f"adjacency must be a dict (p, q) -> bool array or None, got "
                                f"{type(adjacency).__name__}")
    for key in adjacency:
        if not (isinstance(key, tuple) and len(key) == 2 and all(isinstance(v, int | np.integer)
                                                                  and not isinstance(v, bool) for v in key)
                and 0 <= key[0] < key[1] < len(sizes)):
            raise WorldGraphError(f"adjacency keys must be (p, q) with 0 <= p < q < {len(sizes)}, "
                                  f"got {key!r}")
    min_size = strict_int("min_size", min_size, minimum=0)
    near_maximum = strict_int("near_maximum", near_maximum, minimum=0)
    max_nodes = strict_int("max_nodes", max_nodes, minimum=1)
    if max_cliques is not None:
        max_cliques = strict_int("max_cliques", max_cliques, minimum=1)
    if stop_at is not None:
        stop_at = strict_int("stop_at", stop_at, minimum=1)
    if allowed is not None:
        allowed = [np.asarray(a) for a in allowed]
        if len(allowed) != len(sizes) or any(a.dtype != np.bool_ or a.shape != (s,)
                                             for a, s in zip(allowed, sizes, strict=False)):
            raise ShapeError(f"allowed must hold one bool array of shape (sizes[p],) per part ({len(sizes)})")
    k = len(sizes)
    full = [(1 << int(s)) - 1 for s in sizes]
    start = list(full) if allowed is None else [_bits(np.flatnonzero(a)) & f for a, f in zip(allowed, full,
                                                                                             strict=True)]
    order = sorted(range(k), key=lambda p: (start[p].bit_count(), p))
    order = [p for p in order if start[p]] + [p for p in order if not start[p]]
    # packed[d][e]: rows of vertex a of part order[d] against part order[e], packed little-endian
    # (or an int for "all" / "none"); turned into Python-int bitsets lazily, per visited vertex
    packed: list[list[NDArray[np.uint8] | int | tuple[NDArray[np.intp], NDArray[np.intp], int]]] = [
        [0] * k for _ in range(k)]
    for d, p in enumerate(order):
        for e, q in enumerate(order):
            if p == q:
                continue
            key = (min(p, q), max(p, q))
            if key not in adjacency:
                packed[d][e] = 0
                continue
            mat = adjacency[key]
            if mat is None:
                packed[d][e] = full[q]
                continue
            if isinstance(mat, tuple):
                packed[d][e] = _csr(key, mat, sizes, p < q)
                continue
            mat = np.asarray(mat)
            if mat.dtype != np.bool_:
                raise ArgumentTypeError(f"adjacency[{key}] must be a bool array, got dtype {mat.dtype}")
            if mat.shape != (sizes[key[0]], sizes[key[1]]):
                raise WorldGraphError(f"adjacency[{key}] must have shape ({sizes[key[0]]}, {sizes[key[1]]}), "
                                      f"got shape {mat.shape}")
            mat = mat if p < q else mat.T
            packed[d][e] = np.packbits(mat, axis=1, bitorder="little") if mat.shape[1] else 0
    cache: dict[tuple[int, int], list[int]] = {}
    # per part, its rows by kind: constants (int), packed bit rows, CSR rows
    fixed = [[(e, pk) for e, pk in enumerate(packed[d]) if isinstance(pk, int)] for d in range(k)]
    bit_rows = [[(e, pk) for e, pk in enumerate(packed[d]) if isinstance(pk, np.ndarray)] for d in range(k)]
    csr_rows = [[(e, pk) for e, pk in enumerate(packed[d]) if isinstance(pk, tuple)] for d in range(k)]

    def rows_of(d: int, a: int) -> list[int]:
        got = cache.get((d, a))
        if got is None:
            got = [0] * k
            for e, pk in fixed[d]:
                got[e] = pk
            for e, bits in bit_rows[d]:
                got[e] = int.from_bytes(bits[a].tobytes(), "little")
            for e, (indptr, cols, _) in csr_rows[d]:  # sparse: (indptr, cols, size of the other part)
                row = 0
                for c in cols[indptr[a]:indptr[a + 1]].tolist():
                    row |= 1 << c
                got[e] = row
            cache[(d, a)] = got
        return got

    best = [0]
    found: list[tuple[int, tuple[tuple[int, int], ...]]] = []
    nodes = [0]
    complete = [True]
    floor = max(int(min_size), 1)

    def threshold() -> int:
        return max(best[0] - near_maximum, floor)

    done = [False]

    def rec(depth: int, masks: list[int], chosen: list[tuple[int, int]], skipped: list[int]) -> None:
        if done[0]:
            return
        if nodes[0] >= max_nodes:
            complete[0] = False
            done[0] = True
            return
        nodes[0] += 1
        possible = sum(1 for e in range(depth, k) if masks[e])
        if len(chosen) + possible < threshold():
            return
        if depth == k:
            for s in skipped:
                if masks[s]:
                    return  # not maximal: a skipped part still has a compatible vertex
            size = len(chosen)
            if size > best[0]:
                best[0] = size
            found.append((size, tuple(sorted((order[d], a) for d, a in chosen))))
            if stop_at is not None and size >= stop_at:
                done[0] = True
            elif max_cliques is not None and len(found) >= max_cliques:
                done[0] = True
                complete[0] = False
            return
        m = masks[depth]
        while m:
            low = m & -m
            a = low.bit_length() - 1
            m ^= low
            rows = rows_of(depth, a)
            new = [x & r for x, r in zip(masks, rows, strict=True)]
            new[depth] = 0
            chosen.append((depth, a))
            rec(depth + 1, new, chosen, skipped)
            chosen.pop()
        if masks[depth]:
            skipped.append(depth)
            rec(depth + 1, masks, chosen, skipped)
            skipped.pop()
        else:
            rec(depth + 1, masks, chosen, skipped)

    rec(0, [start[p] for p in order], [], [])
    thr = threshold()
    cliques = sorted({c for s, c in found if s >= thr}, key=lambda c: (-len(c), c))
    return CliqueSearch(cliques=cliques, maximum=best[0] if best[0] >= floor else 0,
                        complete=complete[0], nodes=nodes[0])


# ----------------------------------------------------------------------------------------------
# input checks and the consistency graph
# ----------------------------------------------------------------------------------------------
#: Percept standard deviations (m) outside this range are rejected: their squares and inverse
#: squares (the weights of every fit) would under- or overflow together with the coordinates.
SIGMA_RANGE = (1e-12, 1e9)
#: Largest percept coordinate (m) the pose computations accept.
MAX_COORDINATE = 1e9


def check_world_and_percepts(world: WorldModel, percepts: Sequence[Percept]) -> list[Percept]:
    """A non-empty WorldModel and a sequence of Percepts whose scales the fits can handle.

    Raises :class:`~worldgraph.errors.WorldGraphError` naming ``world``, ``percepts`` or
    ``percepts[i]`` (the index of a wrong element, its sigma or covariance scale).
    """
    if not isinstance(world, WorldModel):
        raise ArgumentTypeError(f"world must be a WorldModel, got {type(world).__name__}")
    if len(world) == 0:
        raise EmptyWorldError("the world model has no objects")
    percepts = as_list("percepts", percepts, "perception.Percept", exclude=(Percept,))
    lo, hi = SIGMA_RANGE
    for k, p in enumerate(percepts):
        if not isinstance(p, Percept):
            raise ArgumentTypeError(f"percepts[{k}] must be a perception.Percept, got {type(p).__name__}")
    if not percepts:
        return percepts
    # one vectorised pass (a Percept is already validated: finite, SPD); loops only to name
    sig = np.array([float(p.sigma) for p in percepts])
    bad = np.flatnonzero(~((sig >= lo) & (sig <= hi)))
    if bad.size:
        k = int(bad[0])
        raise OutOfRangeError(f"percepts[{k}].sigma = {sig[k]:.3g} m is outside [{lo:g}, {hi:g}] m, the "
                              "range the association and pose fits can handle (covariance scale "
                              f"{sig[k] ** 2:.3g} m^2)")
    pos = np.array([p.position for p in percepts], dtype=np.float64)
    bad = np.flatnonzero(~np.all(np.abs(pos) <= MAX_COORDINATE, axis=1))
    if bad.size:
        k = int(bad[0])
        raise OutOfRangeError(f"percepts[{k}].position = {pos[k].tolist()} exceeds {MAX_COORDINATE:g} m")
    with_cov = [k for k, p in enumerate(percepts) if p.covariance is not None]
    if with_cov:
        ev = np.linalg.eigvalsh(np.array([percepts[k].covariance for k in with_cov], dtype=np.float64))
        bad = np.flatnonzero(~((ev[:, 0] >= lo * lo) & (ev[:, -1] <= hi * hi)))
        if bad.size:
            k, e = with_cov[int(bad[0])], ev[int(bad[0])]
            raise OutOfRangeError(f"percepts[{k}].covariance has eigenvalues {e[0]:.3g}..{e[-1]:.3g} "
                                  f"m^2, outside [{lo * lo:g}, {hi * hi:g}] m^2 (the range the fits "
                                  "can handle)")
    return percepts


def _check_tolerances(tolerances: object, name: str = "tolerances", world: WorldModel | None = None
                      ) -> AssociationTolerances:
    """The tolerances, with ``gravity_aligned=None`` resolved to the world's flag when a world is
    given."""
    if not isinstance(tolerances, AssociationTolerances):
        raise ArgumentTypeError(f"{name} must be an AssociationTolerances, got {type(tolerances).__name__}")
    if world is not None and tolerances.gravity_aligned is None:
        return replace(tolerances, gravity_aligned=bool(world.gravity_aligned))
    return tolerances


def _check_inputs(world: WorldModel, percepts: Sequence[Percept]) -> list[Percept]:
    percepts = check_world_and_percepts(world, percepts)
    for k, p in enumerate(percepts):
        if p.type not in world.type_index:
            raise UnknownTypeError(f"percepts[{k}] has type {p.type!r}, which is not in the world model; "
                                   f"known types: {list(world.type_index)}")
    return percepts


@dataclass(frozen=True)
class _SupportIndex:
    """Edges of a :class:`_Graph` for vectorised pruning: global vertex ids ``u``/``v`` (vertex
    ``a`` of part ``p`` is ``offsets[p] + a``); ``order`` sorts the ``2 E`` (vertex, other part)
    keys of both edge ends, ``starts`` begins each distinct key and ``key_vertex`` is its vertex;
    ``free_p``/``free_q`` are the unconstrained part pairs."""

    offsets: NDArray[np.int64]
    part_of: NDArray[np.int64]
    u: NDArray[np.int64]
    v: NDArray[np.int64]
    order: NDArray[np.intp]
    starts: NDArray[np.intp]
    key_vertex: NDArray[np.int64]
    free_p: NDArray[np.int64]
    free_q: NDArray[np.int64]


@dataclass(frozen=True)
class _Graph:
    """Consistency graph: part p = percept p, its vertices = objects of p's type.

    ``edges[(p, q)]`` (p < q) holds local index arrays ``(a, b)``, or None when every pair is
    compatible (the percepts are farther apart than the link table reaches).
    """

    objects: list[NDArray[np.intp]]          # per percept: global object indices (local -> global)
    edges: dict[tuple[int, int], tuple[NDArray[np.intp], NDArray[np.intp]] | None]

    @cached_property
    def support_index(self) -> _SupportIndex:
        """All constrained edges as global vertex ids, grouped by (vertex, other part) once, for
        :func:`_prune` (which runs once per clique size tried)."""
        k = len(self.objects)
        sizes = np.array([len(o) for o in self.objects], dtype=np.int64)
        off = np.concatenate([[0], np.cumsum(sizes)])
        us, vs, pus, pvs, free = [], [], [], [], []
        for (p, q), e in self.edges.items():
            if e is None:
                free.append((p, q))
                continue
            a, b = e
            us.append(off[p] + np.asarray(a, dtype=np.int64))
            vs.append(off[q] + np.asarray(b, dtype=np.int64))
            pus.append(np.full(len(a), p, dtype=np.int64))
            pvs.append(np.full(len(b), q, dtype=np.int64))

        def cat(x: list[NDArray]) -> NDArray[np.int64]:
            return np.concatenate(x) if x else np.zeros(0, dtype=np.int64)

        u, v = cat(us), cat(vs)
        keys = np.concatenate([u * k + cat(pvs), v * k + cat(pus)])
        order = np.argsort(keys, kind="stable")
        sk = keys[order]
        starts = np.flatnonzero(np.concatenate([[True], sk[1:] != sk[:-1]])) if len(sk) else \
            np.zeros(0, dtype=np.intp)
        fr = np.array(free, dtype=np.int64).reshape(-1, 2)
        return _SupportIndex(offsets=off, part_of=np.repeat(np.arange(k, dtype=np.int64), sizes), u=u, v=v,
                             order=order, starts=starts, key_vertex=sk[starts] // k if len(sk) else sk,
                             free_p=fr[:, 0], free_q=fr[:, 1])

    def compact(self, alive: list[NDArray[np.bool_]]
                ) -> tuple[list[NDArray[np.intp]], dict[tuple[int, int], tuple[NDArray, NDArray] | None]]:
        """The subgraph of the alive vertices: compacted objects and sparse adjacency (the index
        pairs of the compatible vertices, renumbered), as :func:`maximum_cliques` takes it."""
        new_index = []
        for al in alive:
            idx = np.full(len(al), -1, dtype=np.intp)
            idx[al] = np.arange(int(al.sum()))
            new_index.append(idx)
        objects = [o[al] for o, al in zip(self.objects, alive, strict=True)]
        adjacency: dict[tuple[int, int], tuple[NDArray, NDArray] | None] = {}
        for (p, q), e in self.edges.items():
            if e is None:
                adjacency[(p, q)] = None
                continue
            a, b = e
            keep = alive[p][a] & alive[q][b]
            adjacency[(p, q)] = (new_index[p][a[keep]], new_index[q][b[keep]])
        return objects, adjacency

    def dense(self, alive: list[NDArray[np.bool_]]
              ) -> tuple[list[NDArray[np.intp]], dict[tuple[int, int], NDArray[np.bool_] | None]]:
        """:meth:`compact` with boolean adjacency matrices (for the paper's filters)."""
        objects, sparse = self.compact(alive)
        adjacency: dict[tuple[int, int], NDArray[np.bool_] | None] = {}
        for (p, q), e in sparse.items():
            if e is None:
                adjacency[(p, q)] = None
                continue
            mat = np.zeros((len(objects[p]), len(objects[q])), dtype=bool)
            mat[e[0], e[1]] = True
            adjacency[(p, q)] = mat
        return objects, adjacency


def _local(objects: NDArray[np.intp], glob: NDArray[np.integer]) -> NDArray[np.intp]:
    return np.searchsorted(objects, glob)


#: z scale of the k-d trees that gravity-aligned association queries beyond the link table: a
#: height mismatch of 1 m weighs as 10 m sideways, so other storeys drop out of the query ball.
GRAVITY_Z_SCALE = 10.0


def _is_far(world: WorldModel, percepts: list[Percept], p: int, q: int, tau: float,
            tol: AssociationTolerances, objects: list[NDArray[np.intp]]) -> bool:
    """The percept pair lies beyond the link table and its types are too many for all pairs:
    its candidates come from k-d tree queries (and may be computed for some of p's objects)."""
    *_, covered = _pair_reach(world, percepts, p, q, tau, tol)
    return not (covered or len(objects[p]) * len(objects[q]) <= tol.dense_pair_limit)


def _pair_reach(world: WorldModel, percepts: list[Percept], p: int, q: int, tau: float,
                tol: AssociationTolerances) -> tuple[NDArray[np.float64], float, float, float, bool]:
    """``(diff, d, ztol, reach, covered)`` of the percept pair: the offset from p to q and its
    length, the height tolerance, how far a model distance may differ from ``d`` (``tau``, plus
    ``ztol`` when gravity-aligned), and whether the link table holds every pair within reach."""
    diff = percepts[q].position - percepts[p].position
    d = float(np.linalg.norm(diff))
    ztol = tau if tol.height_tolerance is None else float(tol.height_tolerance)
    reach = tau + (ztol if tol.gravity_aligned else 0.0)
    return diff, d, ztol, reach, d + reach < world.max_link_length + world.link_margin


def _far_index(world: WorldModel, tp: str, tq: str, diff: NDArray[np.float64], d: float, ztol: float,
               tau: float, reach: float, tol: AssociationTolerances) -> FarPairIndex | None:
    """The world's far-pair index of the two types when it covers the percept pair's window."""
    if tol.gravity_aligned:
        if math.hypot(diff[0], diff[1]) + tau >= FAR_PAIR_RANGE or abs(diff[2]) + ztol >= FAR_PAIR_HEIGHT:
            return None
    elif d + reach >= FAR_PAIR_RANGE:
        return None
    return world.far_pairs(tp, tq, bool(tol.gravity_aligned))


def _indexed_candidates(world: WorldModel, index: FarPairIndex, diff: NDArray[np.float64], d: float,
                        ztol: float, tau: float, reach: float, sub: NDArray[np.intp] | None
                        ) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Far percept pair candidates from the world's far-pair index: the pairs in the key window
    (3D distance, or gravity-aligned horizontal distance and dz) whose p object is in ``sub``
    (all when None), tested exactly as the other branches of :func:`_pair_candidates` do.  The
    float32 keys are within :data:`FAR_PAIR_SLACK` of the float64 values, so pairs that pass by
    more than the slack pass the exact test and only the pairs near the edge are computed again
    from the positions."""
    h = math.hypot(diff[0], diff[1])
    gravity = index.dz is not None
    centre, half = (h, tau) if gravity else (d, reach)
    w = index.window(centre - half, centre + half)
    i, j, key = index.i[w], index.j[w], index.key[w]
    keep = np.ones(len(i), dtype=bool)
    if sub is not None:
        mine = np.zeros(len(world), dtype=bool)
        mine[sub] = True
        keep &= mine[i]
    off = np.abs(key - centre)
    inner = off < half - FAR_PAIR_SLACK
    if index.dz is not None:
        offz = np.abs(index.dz[w] - diff[2])
        keep &= offz < ztol + FAR_PAIR_SLACK
        inner &= offz < ztol - FAR_PAIR_SLACK
    edge = np.flatnonzero(keep & ~inner)
    if edge.size:  # the exact tests of _pair_candidates, in float64 from the positions
        dv = world.positions[j[edge]] - world.positions[i[edge]]
        if gravity:
            ok = (np.abs(dv[:, 2] - diff[2]) < ztol) & (np.abs(np.hypot(dv[:, 0], dv[:, 1]) - h) < tau)
        else:
            ok = np.abs(np.linalg.norm(dv, axis=1) - d) < reach
        keep[edge[~ok]] = False
    return i[keep].astype(np.intp), j[keep].astype(np.intp)


def _pair_candidates(world: WorldModel, percepts: list[Percept], p: int, q: int, tau: float,
                     tol: AssociationTolerances, objects: list[NDArray[np.intp]],
                     rows: NDArray[np.intp] | None = None,
                     ) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Model pairs consistent with the percept pair (p, q): local indices ``(a, b)`` into
    ``objects[p]`` and ``objects[q]``.  ``rows`` (local indices into ``objects[p]``; used for far
    pairs, see :func:`_is_far`) restricts p's side to those objects."""
    tp, tq = percepts[p].type, percepts[q].type
    op, oq = objects[p], objects[q]
    diff, d, ztol, reach, covered = _pair_reach(world, percepts, p, q, tau, tol)
    sub = op if rows is None else op[rows]
    exact = False  # the far-pair index branch applies the final tests itself
    i: NDArray[np.integer]  # intp from the link tables and trees, int32 from the far-pair index
    j: NDArray[np.integer]
    if covered:
        i, j, _ = world.link_lengths(tp, tq, d - reach, d + reach)
        if tp == tq:
            i, j = np.concatenate([i, j]), np.concatenate([j, i])
        if rows is not None:
            keep = np.isin(i, sub)
            i, j = i[keep], j[keep]
    elif len(op) * len(oq) <= tol.dense_pair_limit:
        ii, jj = np.meshgrid(sub, oq, indexing="ij")
        i, j = ii.ravel(), jj.ravel()
        dm = np.linalg.norm(world.positions[j] - world.positions[i], axis=1)
        keep = (np.abs(dm - d) < reach) & (i != j)
        i, j = i[keep], j[keep]
    elif (index := _far_index(world, tp, tq, diff, d, ztol, tau, reach, tol)) is not None:
        i, j = _indexed_candidates(world, index, diff, d, ztol, tau, reach, sub if rows is not None else None)
        exact = True
    elif tol.gravity_aligned:
        # beyond the link table, z up: p's objects raised by dz, against q's tree, both with z
        # scaled by GRAVITY_Z_SCALE: the partners lie on a horizontal ring of radius h, thin in
        # z, and the other storeys far outside the query radius; the gravity test below is exact
        s = GRAVITY_Z_SCALE
        h = math.hypot(diff[0], diff[1])
        raised = cKDTree((world.positions[sub] + [0.0, 0.0, diff[2]]) * [1.0, 1.0, s])
        r_hi = math.hypot(h + tau, s * ztol) * (1.0 + 1e-9) + 1e-12
        pairs = raised.sparse_distance_matrix(world.type_tree(tq, s), r_hi, output_type="ndarray")
        shell = pairs["v"] >= (h - tau) * (1.0 - 1e-9)
        i, j = sub[pairs["i"][shell]], oq[pairs["j"][shell]]
        keep = i != j
        i, j = i[keep], j[keep]
    else:
        # beyond the link table: the two types' k-d trees give every pair within d + reach
        # (dual tree, in C); the shell |d_model - d| < reach, with the distances computed as in
        # the other branches, keeps the candidates
        wide = reach * (1.0 + 1e-9) + 1e-12
        tree_p = world.type_tree(tp) if rows is None else cKDTree(world.positions[sub])
        pairs = tree_p.sparse_distance_matrix(world.type_tree(tq), d + wide, output_type="ndarray")
        shell = pairs["v"] > d - wide
        i, j = sub[pairs["i"][shell]], oq[pairs["j"][shell]]
        dm = np.linalg.norm(world.positions[j] - world.positions[i], axis=1)
        keep = (np.abs(dm - d) < reach) & (i != j)
        i, j = i[keep], j[keep]
    if tol.gravity_aligned and len(i) and not exact:
        dv = world.positions[j] - world.positions[i]
        keep = (np.abs(dv[:, 2] - diff[2]) < ztol) & \
            (np.abs(np.hypot(dv[:, 0], dv[:, 1]) - math.hypot(diff[0], diff[1])) < tau)
        i, j = i[keep], j[keep]
    if op is world.type_index[tp] and oq is world.type_index[tq]:  # the usual case: a gather
        rank = world.type_rank
        return rank[i], rank[j]
    return _local(op, i), _local(oq, j)


#: The far pairs of :class:`_LazyGraph` are filled in rounds, cheapest first: each round takes the
#: pairs with at most this many times the rows of the cheapest (counted as at least
#: ``FAR_ROUND_MIN_ROWS``), then prunes.
FAR_ROUND_FACTOR = 2
FAR_ROUND_MIN_ROWS = 64


class _LazyGraph:
    """The consistency graph with the far percept pairs (:func:`_is_far`) filled on demand.

    Pruning for a clique size ``need`` first treats every far pair as unconstrained; that keeps a
    superset of the vertices the exact pruning keeps (pruning is monotone in the edges).  The far
    pairs' candidates are then computed for those vertices only (p's side of each pair; later
    calls add the vertices a smaller ``need`` revives), and the graph of the near pairs plus the
    far candidates found so far is pruned again: exactly, because every vertex it can keep has
    all its far candidates.  Far pairs cost queries for the few objects that fit the near
    pairs, not for every object of their type.
    """

    def __init__(self, world: WorldModel, percepts: list[Percept], tol: AssociationTolerances) -> None:
        self.world, self.percepts, self.tol = world, percepts, tol
        self.objects = [world.type_index[p.type] for p in percepts]
        sig = np.array([p.sigma for p in percepts])
        self.near: dict[tuple[int, int], tuple[NDArray[np.intp], NDArray[np.intp]]] = {}
        self.far: dict[tuple[int, int], tuple[float, NDArray[np.bool_], list, list]] = {}
        for p, q in itertools.combinations(range(len(percepts)), 2):
            tau = float(tol.pair_tolerance(sig[p], sig[q]))
            if _is_far(world, percepts, p, q, tau, tol, self.objects):
                self.far[(p, q)] = (tau, np.zeros(len(self.objects[p]), dtype=bool), [], [])
            else:
                self.near[(p, q)] = _pair_candidates(world, percepts, p, q, tau, tol, self.objects)
        self.free = _Graph(self.objects, {**self.near, **dict.fromkeys(self.far)})
        self._graph: _Graph | None = None if self.far else self.free

    def graph(self, need: int) -> _Graph:
        """A graph whose pruning for ``need`` (or any larger size) equals the full graph's.

        Far pairs are filled in rounds, those with the fewest rows to query first, and the graph
        is pruned again after each round: a far pair counts as unconstrained while some alive
        vertex of its p side has not been queried, and as constrained once all have, so every
        intermediate pruning keeps a superset of the exact one (see the class docstring) while
        the rows left to query shrink with each constraint added."""
        return self.prune(need)[0]

    def prune(self, need: int) -> tuple[_Graph, list[NDArray[np.bool_]]]:
        """:meth:`graph` and its pruning for ``need``."""
        if not self.far:
            return self.free, _prune(self.free, need)
        graph = self._current()
        alive = _prune(graph, need)
        while True:
            pending = sorted((int(np.count_nonzero(alive[key[0]] & ~done)), key)
                             for key, (_, done, _, _) in self.far.items())
            pending = [(n, key) for n, key in pending if n]
            if not pending:
                # every far pair is queried for every alive vertex: constrain them all
                final = self._current(alive)
                return final, _prune(final, need, alive)
            # this round: the cheapest pairs, up to FAR_ROUND_FACTOR times the cheapest one's rows
            limit = FAR_ROUND_FACTOR * max(pending[0][0], FAR_ROUND_MIN_ROWS)
            for n, (p, q) in pending:
                if n > limit:
                    break
                tau, done, a_parts, b_parts = self.far[(p, q)]
                todo = np.flatnonzero(alive[p] & ~done)
                a, b = _pair_candidates(self.world, self.percepts, p, q, tau, self.tol, self.objects, todo)
                a_parts.append(a)
                b_parts.append(b)
                done[todo] = True
            self._graph = None
            graph = self._current(alive)
            alive = _prune(graph, need, alive)

    def _current(self, alive: list[NDArray[np.bool_]] | None = None) -> _Graph:
        """The near pairs plus the far pairs whose p side is queried for every alive vertex
        (``alive`` None: every vertex queried so far); the other far pairs unconstrained."""
        if alive is None and self._graph is not None:
            return self._graph
        edges: dict[tuple[int, int], tuple[NDArray[np.intp], NDArray[np.intp]] | None] = dict(self.near)
        for key, (_, done, a_parts, b_parts) in self.far.items():
            complete = bool(done.all()) if alive is None else not np.any(alive[key[0]] & ~done)
            if a_parts and complete:
                edges[key] = (np.concatenate(a_parts), np.concatenate(b_parts))
            else:
                edges[key] = None
        graph = _Graph(self.objects, dict(sorted(edges.items())))
        if alive is None:
            self._graph = graph
        return graph


def _consistency_graph(world: WorldModel, percepts: list[Percept], tol: AssociationTolerances) -> _Graph:
    objects = [world.type_index[p.type] for p in percepts]
    sig = np.array([p.sigma for p in percepts])
    edges: dict[tuple[int, int], tuple[NDArray[np.intp], NDArray[np.intp]] | None] = {}
    for p, q in itertools.combinations(range(len(percepts)), 2):
        tau = float(tol.pair_tolerance(sig[p], sig[q]))
        edges[(p, q)] = _pair_candidates(world, percepts, p, q, tau, tol, objects)
    return _Graph(objects, edges)


#: :func:`_prune` loops over the part pairs up to this many pairs (16 percepts) and works on all
#: edges at once beyond (the loop costs a few numpy calls per pair and iteration; the vectorised
#: form sorts every edge once per graph).
PRUNE_LOOP_MAX_PAIRS = 120


def _prune(graph: _Graph, need: int, alive: list[NDArray[np.bool_]] | None = None
           ) -> list[NDArray[np.bool_]]:
    """Vertices that have compatible vertices in at least ``need - 1`` other parts (iterated).

    A vertex's support is the number of distinct other parts holding an alive neighbour, plus
    the unconstrained part pairs whose other part still has an alive vertex.  ``alive`` (per part)
    starts the pruning from a set known to hold the result (the result is the largest subset of
    the start that passes, so any superset of it gives the same answer).
    """
    if len(graph.edges) <= PRUNE_LOOP_MAX_PAIRS:
        return _prune_by_pairs(graph, need, alive)
    return _prune_vectorised(graph, need, alive)


def _prune_by_pairs(graph: _Graph, need: int, alive: list[NDArray[np.bool_]] | None = None
                    ) -> list[NDArray[np.bool_]]:
    """:func:`_prune` with a loop over the part pairs; each pair's edges shrink to the alive ones."""
    k = len(graph.objects)
    cur = [np.ones(len(o), dtype=bool) for o in graph.objects] if alive is None else [a.copy() for a in alive]
    edges = dict(graph.edges)
    while True:
        support = [np.zeros(len(a), dtype=np.int64) for a in cur]
        has = [bool(a.any()) for a in cur]
        for (p, q), e in edges.items():
            if e is None:
                if has[q]:
                    support[p] += 1
                if has[p]:
                    support[q] += 1
                continue
            a, b = e
            keep = cur[p][a] & cur[q][b]
            a, b = a[keep], b[keep]
            edges[(p, q)] = (a, b)
            hit = np.zeros(len(cur[p]), dtype=bool)
            hit[a] = True
            support[p] += hit
            hit = np.zeros(len(cur[q]), dtype=bool)
            hit[b] = True
            support[q] += hit
        changed = False
        for p in range(k):
            new = cur[p] & (support[p] >= need - 1)
            if np.count_nonzero(new) != np.count_nonzero(cur[p]):
                cur[p], changed = new, True
        if not changed:
            return cur


def _prune_vectorised(graph: _Graph, need: int, start: list[NDArray[np.bool_]] | None = None
                      ) -> list[NDArray[np.bool_]]:
    """:func:`_prune` over all edges at once (see :meth:`_Graph.support_index`)."""
    ix = graph.support_index
    k, off = len(graph.objects), ix.offsets
    alive = np.ones(int(off[-1]), dtype=bool) if start is None else np.concatenate(
        [np.asarray(a, dtype=bool) for a in start] + [np.zeros(0, dtype=bool)])
    while True:
        keep = alive[ix.u] & alive[ix.v]
        support = np.zeros(len(alive), dtype=np.int64)
        if len(ix.starts):
            hit = np.logical_or.reduceat(np.concatenate([keep, keep])[ix.order], ix.starts)
            support += np.bincount(ix.key_vertex[hit], minlength=len(alive))
        if len(ix.free_p):
            has = np.zeros(k, dtype=bool)
            has[ix.part_of[alive]] = True
            free = np.bincount(ix.free_p, weights=has[ix.free_q], minlength=k) + \
                np.bincount(ix.free_q, weights=has[ix.free_p], minlength=k)
            support += free.astype(np.int64)[ix.part_of]
        new = alive & (support >= need - 1)
        if np.array_equal(new, alive):
            break
        alive = new
    return [alive[off[p]:off[p + 1]].copy() for p in range(k)]


# ----------------------------------------------------------------------------------------------
# chirality, fit cost, hypotheses
# ----------------------------------------------------------------------------------------------
def _cross(a: NDArray, b: NDArray) -> NDArray:
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


#: Point sets with at most this many tetrahedra (C(11, 4)) have every one tested by the mirror
#: check; larger sets test a bounded family of ``2 m - 3`` (see :func:`_tetrahedra`), so memory
#: and time grow linearly with the clique size instead of as C(m, 4).
MAX_ALL_TETRAHEDRA = 330


def _tetrahedra(world: NDArray) -> NDArray[np.intp]:
    """Index quadruples ``(h, q, 4)`` of the mirror check of point sets ``world (h, m, 3)``.

    Small sets: all C(m, 4).  Larger: the widest triangle of each set (the point farthest from the
    centroid, the point farthest from it, the point farthest from their line) with every other
    point (m - 3 tetrahedra; a mirrored member shows against a well-spread base), plus the m
    cyclic runs ``(i, i+1, i+2, i+3)``.
    """
    h, m, _ = world.shape
    if math.comb(m, 4) <= MAX_ALL_TETRAHEDRA:
        q = np.array(list(itertools.combinations(range(m), 4)), dtype=np.intp).reshape(-1, 4)
        return np.broadcast_to(q, (h,) + q.shape)
    rows = np.arange(h)
    a = np.argmax(np.linalg.norm(world - world.mean(axis=1, keepdims=True), axis=2), axis=1)
    b = np.argmax(np.linalg.norm(world - world[rows, a][:, None], axis=2), axis=1)
    c = np.argmax(np.linalg.norm(_cross(world - world[rows, a][:, None],
                                        (world[rows, b] - world[rows, a])[:, None]), axis=2), axis=1)
    idx = np.arange(m)
    base = (idx == a[:, None]) | (idx == b[:, None]) | (idx == c[:, None])
    rest = np.argsort(base, axis=1, kind="stable")[:, : m - 3]
    n = rest.shape[1]
    fan = np.stack([np.broadcast_to(a[:, None], (h, n)), np.broadcast_to(b[:, None], (h, n)),
                    np.broadcast_to(c[:, None], (h, n)), rest], axis=2)
    runs = (idx[:, None] + np.arange(4)) % m
    return np.concatenate([fan, np.broadcast_to(runs, (h, m, 4))], axis=1)


def _chirality_ok(ego: NDArray, world: NDArray, sigmas: NDArray, tol: AssociationTolerances
                  ) -> NDArray[np.bool_]:
    """Per point set: no tested tetrahedron of the members has a significant signed volume of
    opposite sign (:func:`_tetrahedra`: all of them up to 11 members, a linear-size family above).

    ``ego, world (h, m, 3)``, ``sigmas (h, m)``.  With ``gravity_aligned`` triangles are tested
    too: the sign of the z component of their normal.
    """
    h, m, _ = ego.shape
    ok = np.ones(h, dtype=bool)
    if m < 3 or h == 0:
        return ok
    hh = np.arange(h)[:, None, None]
    quads = _tetrahedra(world) if m >= 4 else np.zeros((h, 0, 4), dtype=np.intp)
    if m >= 4:
        e = ego[hh, quads]      # (h, q, 4, 3)
        w = world[hh, quads]
        de, dw = e[:, :, 1:] - e[:, :, :1], w[:, :, 1:] - w[:, :, :1]
        ve = np.sum(de[:, :, 0] * _cross(de[:, :, 1], de[:, :, 2]), axis=-1)
        vw = np.sum(dw[:, :, 0] * _cross(dw[:, :, 1], dw[:, :, 2]), axis=-1)
        # std of 6V under isotropic point noise: |d(6V)/d point c| = twice the opposite face's area
        s = sigmas[hh, quads]
        var = np.zeros(ve.shape)
        for drop in range(4):
            i0, i1, i2 = (c for c in range(4) if c != drop)
            area2 = np.linalg.norm(_cross(w[:, :, i1] - w[:, :, i0], w[:, :, i2] - w[:, :, i0]), axis=-1)
            var += area2**2 * s[:, :, drop] ** 2
        gate = tol.chirality_sigmas * tol.pair_factor * np.sqrt(var)
        bad = (np.abs(vw) > gate) & (np.abs(ve) > gate) & (np.sign(ve) != np.sign(vw))
        ok &= ~bad.any(axis=1)
    if tol.gravity_aligned:
        if math.comb(m, 3) <= MAX_ALL_TETRAHEDRA:
            t3 = np.array(list(itertools.combinations(range(m), 3)), dtype=np.intp)
            tri = np.broadcast_to(t3, (h,) + t3.shape)
        else:
            tri = np.concatenate([quads[:, :, [0, 1, 3]], quads[:, :, [0, 2, 3]], quads[:, :, :3]], axis=1)
        e = ego[hh, tri]
        w = world[hh, tri]
        ne = _cross(e[:, :, 1] - e[:, :, 0], e[:, :, 2] - e[:, :, 0])[..., 2]
        nw = _cross(w[:, :, 1] - w[:, :, 0], w[:, :, 2] - w[:, :, 0])[..., 2]
        s = sigmas[hh, tri].max(axis=2)
        span = np.max(np.linalg.norm(w - w[:, :, :1], axis=-1), axis=-1)
        gate = tol.chirality_sigmas * tol.pair_factor * 2.0 * s * span
        bad = (np.abs(nw) > gate) & (np.abs(ne) > gate) & (np.sign(ne) != np.sign(nw))
        ok &= ~bad.any(axis=1)
    return ok


class _Nearest:
    """Nearest same-type model object of predicted percept positions (one k-d tree per type)."""

    def __init__(self, world: WorldModel, percepts: list[Percept]) -> None:
        self.world = world
        self.types = sorted({p.type for p in percepts})
        self.by_type = {t: np.array([i for i, p in enumerate(percepts) if p.type == t]) for t in self.types}
        self.objects = {t: world.type_index[t] for t in self.types}
        self.trees = {t: world.type_tree(t) for t in self.types}

    def query(self, pred: NDArray[np.float64], scale: NDArray[np.float64], cap: float
              ) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
        """Squared normalised distance (capped) and object index for ``pred (h, k, 3)``."""
        h, k, _ = pred.shape
        r2 = np.full((h, k), cap)
        obj = np.full((h, k), -1, dtype=np.intp)
        for t in self.types:
            idx = self.by_type[t]
            pts = pred[:, idx].reshape(-1, 3)
            bound = float(math.sqrt(cap) * scale[idx].max())
            dist, j = self.trees[t].query(pts, k=1, distance_upper_bound=bound)
            dist = dist.reshape(h, len(idx))  # type: ignore[union-attr]  # pts is 2-D: arrays, not floats
            j = j.reshape(h, len(idx))
            found = np.isfinite(dist)
            d2 = np.where(found, dist, 0.0) ** 2 / scale[idx] ** 2
            inside = found & (d2 < cap)
            r2[:, idx] = np.where(inside, d2, cap)
            obj[:, idx] = np.where(inside, self.objects[t][np.where(found, j, 0)], -1)
        return r2, obj


#: At most this many subsets of failed or outlier-ridden cliques are fitted per association.
MAX_SUBSETS = 400


_PairSet = tuple[tuple[int, int], ...]


def _fit_group(world: WorldModel, ego_all: NDArray, sig_all: NDArray, group: list[_PairSet],
               tol: AssociationTolerances, chirality: bool) -> tuple[list[_PairSet], NDArray, list[_PairSet]]:
    """Weighted Kabsch of pair sets of one size.

    Returns the kept sets, their poses ``(h, 4, 4)`` and the subsets worth trying instead:
    every leave-one-out subset of a mirror match, and a set without its worst member when that
    member is a gross outlier of the set's own fit (a false percept that fits the pairwise
    distances of the true matches, but not their 3D arrangement).
    """
    arr = np.array(group)                          # (h, m, 2)
    m = arr.shape[1]
    pi, oi = arr[:, :, 0], arr[:, :, 1]
    ego, wpts, sig = ego_all[pi], world.positions[oi], sig_all[pi]
    centred = wpts - wpts.mean(axis=1, keepdims=True)
    sv = np.linalg.svd(centred, compute_uv=False)
    good = sv[:, 1] > 1e-6 * np.maximum(sv[:, 0], 1e-300)
    mirror = np.zeros(len(group), dtype=bool)
    if chirality:  # in blocks: at most ~2e5 tetrahedra in memory at once
        per_set = len(_tetrahedra(wpts[:1])[0]) if m >= 4 and len(group) else 1
        step = max(1, 200_000 // max(per_set, 1))
        for s in range(0, len(group), step):
            mirror[s:s + step] = ~_chirality_ok(ego[s:s + step], wpts[s:s + step], sig[s:s + step], tol)
    children: list[tuple[tuple[int, int], ...]] = []
    if m > 3:
        for h in np.flatnonzero(good & mirror):
            children.extend(group[h][:j] + group[h][j + 1:] for j in range(m))
    good &= ~mirror
    if not good.any():
        return [], np.zeros((0, 4, 4)), children
    rot, t = weighted_kabsch_batch(ego[good], wpts[good], 1.0 / sig[good] ** 2)
    mats = np.tile(np.eye(4), (len(rot), 1, 1))
    mats[:, :3, :3] = rot
    mats[:, :3, 3] = t
    kept = [g for g, ok in zip(group, good, strict=True) if ok]
    if m > 3:
        res = np.einsum("hij,hkj->hki", rot, ego[good]) + t[:, None] - wpts[good]
        r2 = np.sum(res**2, axis=2) / (tol.residual_factor * sig[good]) ** 2
        worst = np.argmax(r2, axis=1)
        for h in np.flatnonzero(r2[np.arange(len(kept)), worst] > tol.cost_cap):
            j = int(worst[h])
            children.append(kept[h][:j] + kept[h][j + 1:])
    return kept, mats, children


def _fit_all(world: WorldModel, percepts: list[Percept], candidates: list[tuple[tuple[int, int], ...]],
             tol: AssociationTolerances, chirality: bool = True) -> list[AssociationHypothesis]:
    """Weighted Kabsch on each pair set, then the robust cost of all percepts.

    Pair sets with fewer than 3 or collinear model points, and (``chirality``) mirror matches,
    are dropped; in place of a mirror match, or of a set with a gross outlier of its own fit,
    its subsets one member smaller are tried (at most :data:`MAX_SUBSETS` in all), so that a
    false percept which joined the true matches cannot hide them.  Sets of one size are
    processed together.
    """
    if not candidates:
        return []
    ego_all = np.array([p.position for p in percepts])
    sig_all = np.array([p.sigma for p in percepts])
    seen: set[tuple[tuple[int, int], ...]] = set()
    queue = []
    for pairs in candidates:
        key = tuple(sorted(pairs))
        if len(key) >= 3 and key not in seen:
            seen.add(key)
            queue.append(key)
    kept: list[tuple[tuple[int, int], ...]] = []
    poses = []
    budget = MAX_SUBSETS
    first = True
    while queue:
        by_size: dict[int, list[tuple[tuple[int, int], ...]]] = {}
        for pairs in queue:
            by_size.setdefault(len(pairs), []).append(pairs)
        queue = []
        for size in sorted(by_size, reverse=True):
            sets, mats, children = _fit_group(world, ego_all, sig_all, by_size[size], tol, chirality)
            kept.extend(sets)
            poses.append(mats)
            if not first:  # one level: a single false percept joins a true clique
                continue
            for child in children:
                if budget > 0 and len(child) >= 3 and child not in seen:
                    seen.add(child)
                    queue.append(child)
                    budget -= 1
        first = False
    if not kept:
        return []
    mats = np.concatenate(poses)
    pred = np.einsum("hij,kj->hki", mats[:, :3, :3], ego_all) + mats[:, None, :3, 3]
    scale = tol.residual_factor * sig_all
    r2, obj = _Nearest(world, percepts).query(pred, scale, tol.cost_cap)
    costs = r2.sum(axis=1)
    out = []
    for h, pairs in enumerate(kept):
        clique_obj = dict(pairs)
        used = set(clique_obj.values())
        validated = []
        for p in range(len(percepts)):
            o = int(obj[h, p])
            if p not in clique_obj and o >= 0 and o not in used:
                used.add(o)
                validated.append((p, o))
        out.append(AssociationHypothesis(pairs=pairs, cost=float(costs[h]), size=len(pairs),
                                         world_from_ego=mats[h], validated=tuple(validated),
                                         inliers=int(np.sum(obj[h] >= 0))))
    return out


def same_pose(a: NDArray, b: NDArray, tol: AssociationTolerances) -> bool:
    """Two ``world_from_ego`` (4, 4) poses closer than ``tol.distinct_translation`` (m) and
    ``tol.distinct_angle`` (rad)."""
    return _same_pose(rigid_transform("a", a), rigid_transform("b", b), _check_tolerances(tol, "tol"))


def _same_pose(a: NDArray, b: NDArray, tol: AssociationTolerances) -> bool:
    """:func:`same_pose` of checked transforms (no checks: it runs for every pair of ranked
    hypotheses); the angle as :func:`~worldgraph.pose.rotation_angle`."""
    if float(np.linalg.norm(a[:3, 3] - b[:3, 3])) >= tol.distinct_translation:
        return False
    c = (float(np.sum(a[:3, :3] * b[:3, :3])) - 1.0) / 2.0  # trace(Ra^T Rb)
    return math.acos(min(max(c, -1.0), 1.0)) < tol.distinct_angle


def _rank(hyps: list[AssociationHypothesis], tol: AssociationTolerances, limit: int
          ) -> list[AssociationHypothesis]:
    """By cost; a hypothesis is merged into a cheaper one with the same pose unless they match
    some percept to different objects (a close percept matched to the neighbour of its object
    moves the pose only a little, but it is another hypothesis)."""
    hyps = sorted(hyps, key=lambda h: (h.cost, -h.size, h.pairs))
    kept: list[AssociationHypothesis] = []
    matched: list[dict[int, int]] = []
    for h in hyps:
        mine = dict(h.all_pairs)
        if any(_same_pose(h.world_from_ego, g.world_from_ego, tol)
               and all(m.get(p, o) == o for p, o in mine.items())
               for g, m in zip(kept, matched, strict=True)):
            continue
        matched.append(mine)
        kept.append(h)
        if len(kept) >= limit:
            break
    return kept


def is_ambiguous(hypotheses: Sequence[AssociationHypothesis],
                 tolerances: AssociationTolerances = ASSOCIATION_TOLERANCES) -> bool:
    """The best two hypotheses have costs within ``ambiguity_margin`` and poses that differ."""
    hypotheses = _check_hypotheses(hypotheses)
    _check_tolerances(tolerances)
    if len(hypotheses) < 2:
        return False
    poses = [rigid_transform(f"hypotheses[{i}].world_from_ego", h.world_from_ego)
             for i, h in enumerate(hypotheses[:2])]
    costs = [finite_float(f"hypotheses[{i}].cost", h.cost) for i, h in enumerate(hypotheses[:2])]
    return (costs[1] - costs[0] < tolerances.ambiguity_margin
            and not _same_pose(poses[0], poses[1], tolerances))


# ----------------------------------------------------------------------------------------------
# the paper's filters
# ----------------------------------------------------------------------------------------------
def proximity_filter(world: WorldModel, percepts: Sequence[Percept],
                     tolerances: AssociationTolerances = ASSOCIATION_TOLERANCES) -> dict:
    """Proximity filtering (paper eq. 1 and the intersection ``psi_act``).

    For every percept pair (p, q) the model links of the same type pair whose length lies
    within ``tau`` of the percept distance (``tau`` from the largest sigma of the percepts of
    the two types, as the paper's ``tau = max eps_k``, widened to ``n_sigma`` standard
    deviations); then the intersection: a model object stays a candidate of percept p only
    while it has a link to a candidate of every other percept (iterated to a fixed point).

    Returns
    -------
    dict
        ``"candidates"``: list, per percept, of the surviving global object indices;
        ``"links"``: dict (p, q) -> (k, 2) int array of surviving (object of p, object of q);
        ``"adjacency"``: the same as boolean matrices over each percept's objects of its type;
        ``"graph"``: the surviving part of ``world.graph`` as a networkx subgraph view
        (:func:`filtered_graph_view`).
    """
    percepts = _check_inputs(world, percepts)
    tolerances = _check_tolerances(tolerances, world=world)
    objects = [world.type_index[p.type] for p in percepts]
    k = len(percepts)
    sig = np.array([p.sigma for p in percepts])
    types = [p.type for p in percepts]
    edges: dict[tuple[int, int], tuple[NDArray[np.intp], NDArray[np.intp]] | None] = {}
    for p, q in itertools.combinations(range(k), 2):
        theta = [s for s, t in zip(sig, types, strict=True) if t in (types[p], types[q])]
        smax = max(theta)
        tau = float(tolerances.pair_tolerance(smax, smax))
        edges[(p, q)] = _pair_candidates(world, percepts, p, q, tau, tolerances, objects)
    graph = _Graph(objects, edges)
    alive = _prune(graph, k)
    compact, dense = graph.dense(alive)
    adjacency = {key: np.ones((len(compact[key[0]]), len(compact[key[1]])), bool) if m is None else m
                 for key, m in dense.items()}
    return _filtered(world, compact, adjacency, [np.ones(len(o), bool) for o in compact])


def _sparse(objects: list[NDArray[np.intp]], adjacency: dict) -> _Graph:
    # each m is 2-D, so np.nonzero gives the (rows, cols) pair
    return _Graph(objects, {key: np.nonzero(m) for key, m in adjacency.items()})  # type: ignore[misc]


def _filtered(world: WorldModel, objects: list[NDArray[np.intp]], adjacency: dict,
              alive: list[NDArray[np.bool_]]) -> dict:
    adj = {key: mat & alive[key[0]][:, None] & alive[key[1]][None, :] for key, mat in adjacency.items()}
    links = {}
    for (p, q), mat in adj.items():
        a, b = np.nonzero(mat)
        links[(p, q)] = np.column_stack([objects[p][a], objects[q][b]])
    candidates = [o[al] for o, al in zip(objects, alive, strict=True)]
    return {"candidates": candidates, "links": links, "adjacency": adj, "objects": objects,
            "alive": alive, "graph": filtered_graph_view(world, candidates, links)}


def filtered_graph_view(world: WorldModel, candidates: Sequence[NDArray[np.intp]],
                        links: dict[tuple[int, int], NDArray[np.intp]]) -> nx.Graph:
    """The part of ``world.graph`` that survives a filter: a read-only subgraph view (networkx)
    of the candidate objects and of the proximity edges that some surviving link uses.

    ``world.graph`` holds the pairs closer than ``max_link_length``; links between percepts
    farther apart than that have no edge there and so do not show in the view (they are in
    the filter's ``"links"``).
    """
    if not isinstance(world, WorldModel):
        raise ArgumentTypeError(f"world must be a WorldModel, got {type(world).__name__}")
    if candidates is None or isinstance(candidates, str | bytes) or not isinstance(links, dict):
        raise ArgumentTypeError("candidates must be a sequence of object-index arrays and links a dict, got "
                                f"{type(candidates).__name__} and {type(links).__name__}")
    cand_arrays = []
    for i, c in enumerate(candidates):
        try:
            arr = np.asarray(c)
        except (TypeError, ValueError) as exc:
            raise WorldGraphError(f"candidates[{i}] must be an array of object indices") from exc
        if arr.ndim != 1 or (arr.size and (arr.dtype.kind not in "iu" or arr.min() < 0
                                           or arr.max() >= len(world))):
            raise WorldGraphError(f"candidates[{i}] must be object indices in [0, {len(world)}), "
                                  f"got {arr.tolist()!r:.200}")
        cand_arrays.append(arr)
    link_arrays = []
    for key, pairs in links.items():
        try:
            arr = np.asarray(pairs)
        except (TypeError, ValueError) as exc:
            raise WorldGraphError(f"links[{key!r}] must be a (n, 2) array of object indices") from exc
        if arr.size == 0:
            continue
        if arr.ndim != 2 or arr.shape[1] != 2 or arr.dtype.kind not in "iu" or arr.min() < 0 \
                or arr.max() >= len(world):
            raise WorldGraphError(f"links[{key!r}] must be a (n, 2) array of object indices, "
                                  f"got {arr.tolist()!r:.200}")
        link_arrays.append(arr)
    nodes = {int(o) for c in cand_arrays for o in c}
    edges: set[tuple[int, int]] = set()
    for pairs in link_arrays:
        for a, b in pairs.tolist():
            edges.add((a, b) if a <= b else (b, a))
    return nx.subgraph_view(world.graph, filter_node=nodes.__contains__,
                            filter_edge=lambda u, v: (min(u, v), max(u, v)) in edges)


def consistency_graph(world: WorldModel, percepts: Sequence[Percept],
                      tolerances: AssociationTolerances = ASSOCIATION_TOLERANCES,
                      min_size: int | None = None) -> nx.Graph:
    """The typed consistency graph of :func:`associate` ("clique") as a networkx graph.

    A node ``(p, o)`` pairs percept ``p`` with an object ``o`` of its type (attributes
    ``percept``, ``object``, ``type``); an edge joins two pairs whose percept and model distances
    agree within the gate (and that use different percepts and objects).  Only the pairs that can
    still be in a clique of ``min_size`` (default ``tolerances.min_clique_size``) are kept, as
    :func:`associate` prunes them.  Its maximal cliques are the association candidates (the array
    search in :func:`maximum_cliques` finds the largest of them without building this graph).
    """
    percepts = _check_inputs(world, percepts)
    tolerances = _check_tolerances(tolerances, world=world)
    need = tolerances.min_clique_size if min_size is None else strict_int("min_size", min_size, minimum=1)
    graph = _consistency_graph(world, percepts, tolerances)
    alive = _prune(graph, need)
    g: nx.Graph[tuple[int, int]] = nx.Graph()
    for p, (objs, al) in enumerate(zip(graph.objects, alive, strict=True)):
        g.add_nodes_from(((p, int(o)), {"percept": p, "object": int(o), "type": percepts[p].type})
                         for o in objs[al])
    for (p, q), e in graph.edges.items():
        if e is None:
            a, b = np.nonzero(np.outer(alive[p], alive[q]))
        else:
            a, b = e
            keep = alive[p][a] & alive[q][b]
            a, b = a[keep], b[keep]
        op, oq = graph.objects[p][a], graph.objects[q][b]
        diff = op != oq
        g.add_edges_from(zip(((p, int(o)) for o in op[diff]), ((q, int(o)) for o in oq[diff]), strict=True))
    return g


def _frames(a: NDArray, b: NDArray, c: NDArray) -> tuple[NDArray, NDArray]:
    """Rotations (m, 3, 3) of the eq.-5 frames of point triples (m, 3) each, and a validity mask."""
    ab = b - a
    nab = np.linalg.norm(ab, axis=1)
    d1 = ab / np.where(nab > 0, nab, 1.0)[:, None]
    cr = np.cross(d1, c - a)
    ncr = np.linalg.norm(cr, axis=1)
    ok = (nab > 0) & (ncr > 1e-9 * np.maximum(nab, 1e-300))
    d2 = cr / np.where(ncr > 0, ncr, 1.0)[:, None]
    d3 = np.cross(d1, d2)
    return np.stack([d1, d2, d3], axis=2), ok


def _check_proximity(world: WorldModel, percepts: list[Percept], proximity: object
                     ) -> tuple[list[NDArray[np.intp]], dict[tuple[int, int], NDArray[np.bool_]]]:
    """The ``"objects"`` and a copy of the ``"adjacency"`` of a :func:`proximity_filter` result for
    these percepts, checked (shapes, keys, object types)."""
    k = len(percepts)
    if not isinstance(proximity, dict) or "objects" not in proximity or "adjacency" not in proximity:
        raise ArgumentTypeError("proximity must be the dict returned by proximity_filter (with 'objects' and "
                                f"'adjacency'), got {type(proximity).__name__}")
    objects_in, adjacency = proximity["objects"], proximity["adjacency"]
    if not isinstance(objects_in, list | tuple) or not isinstance(adjacency, dict):
        raise ShapeError("proximity['objects'] must be a list of object arrays and proximity['adjacency'] a "
                         f"dict, got {type(objects_in).__name__} and {type(adjacency).__name__}")
    if len(objects_in) != k:
        raise ShapeError(f"percepts has {k} percepts but proximity['objects'] has {len(objects_in)} entries: "
                         "pass the percepts proximity_filter was given")
    objects = []
    for p, o in enumerate(objects_in):
        arr = np.asarray(o)
        if arr.ndim != 1 or (arr.size and arr.dtype.kind not in "iu") or \
                not np.all(np.isin(arr, world.type_index[percepts[p].type])):
            raise WorldGraphError(f"proximity['objects'][{p}] must be indices of the objects of type "
                                  f"{percepts[p].type!r}, got {arr.tolist()!r:.200}")
        objects.append(arr.astype(np.intp))
    adj = {}
    for p, q in itertools.combinations(range(k), 2):
        mat = np.asarray(adjacency.get((p, q)) if (p, q) in adjacency else np.zeros((0, 0)))
        if mat.dtype != np.bool_ or mat.shape != (len(objects[p]), len(objects[q])):
            raise ShapeError(f"proximity['adjacency'][({p}, {q})] must be a bool array of shape "
                             f"({len(objects[p])}, {len(objects[q])}), got {mat.dtype} {mat.shape}")
        adj[(p, q)] = mat.copy()
    return objects, adj


def orientation_filter(world: WorldModel, percepts: Sequence[Percept], proximity: dict,
                       tolerances: AssociationTolerances = ASSOCIATION_TOLERANCES) -> dict:
    """Orientation filtering (paper eqs. 2-3) of the output of :func:`proximity_filter`.

    For every non-collinear percept triple (i, j, k) the signature ``V = R_ijk^T (x_j - x_k)``
    (the displacement in the eq.-5 frame of the triple) is compared with the signatures of the
    model triples (u, v, w) linked in the proximity result: accepted when ``|V_p - V_m| <
    mu_max`` (eq. 2) and the angle between them is below ``kappa_max`` (eq. 3).  Links that no
    accepted triple uses are dropped, then the intersection is iterated again.

    Returns
    -------
    dict
        Same layout as :func:`proximity_filter`.
    """
    percepts = _check_inputs(world, percepts)
    tolerances = _check_tolerances(tolerances, world=world)
    k = len(percepts)
    objects, adj = _check_proximity(world, percepts, proximity)
    x = np.array([p.position for p in percepts])
    sig = np.array([p.sigma for p in percepts])
    X = world.positions
    if k >= 3:
        support = {key: np.zeros_like(m) for key, m in adj.items()}
        checked = {key: False for key in adj}
        for i, j, kk in itertools.combinations(range(k), 3):
            rp, okp = _frames(x[i][None], x[j][None], x[kk][None])
            if not okp[0]:
                continue
            for key in ((i, j), (i, kk), (j, kk)):
                checked[key] = True
            vp = rp[0].T @ (x[j] - x[kk])
            spread = math.sqrt(sig[i] ** 2 + sig[j] ** 2 + sig[kk] ** 2)
            mu = tolerances.mu_max if tolerances.mu_max is not None else float(
                tolerances.n_sigma * tolerances.pair_factor * spread + tolerances.min_tolerance)
            a_ij, a_ik, a_jk = adj[(i, j)], adj[(i, kk)], adj[(j, kk)]
            u, v = np.nonzero(a_ij)
            if len(u) == 0:
                continue
            cand = a_ik[u] & a_jk[v]
            rows, w = np.nonzero(cand)
            if len(rows) == 0:
                continue
            u, v = u[rows], v[rows]
            Xu, Xv, Xw = X[objects[i][u]], X[objects[j][v]], X[objects[kk][w]]
            rm, okm = _frames(Xu, Xv, Xw)
            vm = np.einsum("mji,mj->mi", rm, Xv - Xw)
            dist = np.linalg.norm(vm - vp, axis=1)
            cosang = (vm @ vp) / np.maximum(np.linalg.norm(vm, axis=1) * np.linalg.norm(vp), 1e-300)
            acc = okm & (dist < mu) & (np.arccos(np.clip(cosang, -1, 1)) < tolerances.kappa_max)
            u, v, w = u[acc], v[acc], w[acc]
            support[(i, j)][u, v] = True
            support[(i, kk)][u, w] = True
            support[(j, kk)][v, w] = True
        for key in adj:
            if checked[key]:
                adj[key] = adj[key] & support[key]
    alive = _prune(_sparse(objects, adj), k)
    return _filtered(world, objects, adj, alive)


# ----------------------------------------------------------------------------------------------
# associate
# ----------------------------------------------------------------------------------------------
def _hypotheses_from_cliques(world: WorldModel, percepts: list[Percept],
                             graph_objects: list[NDArray[np.intp]],
                             cliques: list[tuple[tuple[int, int], ...]], tol: AssociationTolerances,
                             searched: NDArray[np.intp]) -> list[AssociationHypothesis]:
    """Fit every clique; ``searched[p]`` is the index in ``percepts`` of the graph's percept p."""
    sets = [tuple((int(searched[p]), int(graph_objects[p][a])) for p, a in clique)
            for clique in cliques[:tol.max_cliques]]
    return _fit_all(world, percepts, sets, tol)


def _search_subset(percepts: list[Percept], limit: int) -> NDArray[np.intp]:
    """Indices of the ``limit`` most certain percepts (smallest sigma; ties by type and position,
    so the choice does not depend on the percept order), in increasing index order."""
    if len(percepts) <= limit:
        return np.arange(len(percepts))
    order = sorted(range(len(percepts)),
                   key=lambda i: (percepts[i].sigma, percepts[i].type, *percepts[i].position.tolist()))
    return np.sort(np.array(order[:limit], dtype=np.intp))


def associate(world: WorldModel, percepts: Sequence[Percept],
              tolerances: AssociationTolerances = ASSOCIATION_TOLERANCES, method: str = "clique",
              max_hypotheses: int | None = None) -> list[AssociationHypothesis]:
    """Ranked association hypotheses of ``percepts`` (ego frame) to the objects of ``world``.

    Parameters
    ----------
    world : WorldModel
    percepts : sequence of perception.Percept
        Every type must be a type of the world (filter unknown ones before; :func:`localize`
        does).
    tolerances : AssociationTolerances
    method : {"clique", "paper"}
        See the module docstring.
    max_hypotheses : int, optional
        Default ``tolerances.max_hypotheses``.

    Returns
    -------
    list of AssociationHypothesis
        By increasing robust cost; poses within ``distinct_translation``/``distinct_angle`` of
        a better hypothesis are merged into it.  Empty when no clique of ``min_clique_size``
        (or, for "paper", no complete assignment) exists.

    Raises
    ------
    UnknownTypeError
        A percept type the world does not have.
    TooFewPerceptsError
        Fewer than ``min_clique_size`` percepts.
    """
    if not isinstance(method, str) or method not in ASSOCIATION_METHODS:
        raise WorldGraphError(f"method must be one of {ASSOCIATION_METHODS}, got {method!r}")
    percepts = _check_inputs(world, percepts)
    tol = _check_tolerances(tolerances, world=world)
    k = len(percepts)
    if k < tol.min_clique_size:
        raise TooFewPerceptsError(f"association needs at least {tol.min_clique_size} percepts, got {k}")
    limit = tol.max_hypotheses if max_hypotheses is None else strict_int("max_hypotheses", max_hypotheses,
                                                                          minimum=1)
    searched = _search_subset(percepts, int(tol.max_search_percepts))
    sub = [percepts[i] for i in searched]
    k = len(sub)
    if method == "paper":
        prox = proximity_filter(world, sub, tol)
        filt = orientation_filter(world, sub, prox, tol)
        sizes = [len(o) for o in filt["objects"]]
        search = maximum_cliques(sizes, filt["adjacency"], min_size=k, near_maximum=0,
                                 max_nodes=tol.max_nodes, allowed=filt["alive"])
        hyps = _hypotheses_from_cliques(world, percepts, filt["objects"], search.cliques, tol, searched)
        return _rank(hyps, tol, limit)

    lazy = _LazyGraph(world, sub, tol)
    # find the maximum size with strong pruning first (the first clique found of size ``need``
    # is a maximum one: larger ones were ruled out before), then enumerate down to max - near
    best = 0
    for need in range(k, tol.min_clique_size - 1, -1):
        graph, alive = lazy.prune(need)
        if sum(bool(a.any()) for a in alive) < need:
            continue
        objects, adjacency = graph.compact(alive)
        search = maximum_cliques([len(o) for o in objects], adjacency, min_size=need, near_maximum=0,
                                 max_nodes=tol.max_nodes, stop_at=need)
        if search.maximum >= need:
            best = search.maximum
            break
    if best == 0:
        return []
    floor = max(best - tol.near_maximum, tol.min_clique_size)
    graph, alive = lazy.prune(floor)
    objects, adjacency = graph.compact(alive)
    search = maximum_cliques([len(o) for o in objects], adjacency, min_size=floor,
                             near_maximum=tol.near_maximum, max_nodes=tol.max_nodes,
                             max_cliques=tol.max_cliques)
    cliques = search.cliques
    if not search.complete and best > floor:
        # truncated: make sure the maximum cliques themselves are among the candidates
        top = maximum_cliques([len(o) for o in objects], adjacency, min_size=best, near_maximum=0,
                              max_nodes=tol.max_nodes, max_cliques=tol.max_cliques)
        cliques = sorted(set(top.cliques) | set(cliques), key=lambda c: (-len(c), c))
    hyps = _hypotheses_from_cliques(world, percepts, objects, cliques, tol, searched)
    if not hyps and floor > tol.min_clique_size:
        # every large clique was a mirror or degenerate: fall back to all sizes
        graph, alive = lazy.prune(tol.min_clique_size)
        objects, adjacency = graph.compact(alive)
        search = maximum_cliques([len(o) for o in objects], adjacency, min_size=tol.min_clique_size,
                                 near_maximum=k, max_nodes=tol.max_nodes, max_cliques=tol.max_cliques)
        hyps = _hypotheses_from_cliques(world, percepts, objects, search.cliques, tol, searched)
    ranked = _rank(hyps, tol, limit)
    if not search.complete:
        ranked = [replace(h, complete=False) for h in ranked]
    return ranked


def _check_hypotheses(hypotheses: object) -> list[AssociationHypothesis]:
    if hypotheses is None or isinstance(hypotheses, str | bytes | AssociationHypothesis):
        raise ArgumentTypeError(f"hypotheses must be a sequence of AssociationHypothesis, "
                                f"got {type(hypotheses).__name__}")
    try:
        hyps = list(hypotheses)  # type: ignore[call-overload]
    except TypeError as exc:
        raise ArgumentTypeError(f"hypotheses must be a sequence of AssociationHypothesis, "
                                f"got {type(hypotheses).__name__}") from exc
    for i, h in enumerate(hyps):
        if not isinstance(h, AssociationHypothesis):
            raise ArgumentTypeError(f"hypotheses[{i}] must be an AssociationHypothesis, "
                                    f"got {type(h).__name__}")
    return hyps


def discriminator(world: WorldModel, hypotheses: Sequence[AssociationHypothesis],
                  max_range: float | None = None) -> int:
    """The model object whose predicted ego position differs most between the best two hypotheses.

    The paper's active validation (section 2.3, "Hypotheses Validation"): look for this object
    to tell the hypotheses apart.

    Parameters
    ----------
    world : WorldModel
    hypotheses : sequence of AssociationHypothesis
        At least two; the first two are compared.
    max_range : float, optional
        Only objects within this distance (m) of both hypothesised robot positions (visible
        from both); all objects when None or when none qualifies.

    Returns
    -------
    int
        Global object index.
    """
    if not isinstance(world, WorldModel):
        raise ArgumentTypeError(f"world must be a WorldModel, got {type(world).__name__}")
    hyps = _check_hypotheses(hypotheses)
    if len(hyps) < 2:
        raise TooFewPerceptsError(f"the discriminator needs two hypotheses, got {len(hyps)}")
    if max_range is not None:
        max_range = positive_float("max_range", max_range)
    poses = [rigid_transform(f"hypotheses[{i}].world_from_ego", h.world_from_ego)
             for i, h in enumerate(hyps[:2])]
    X = world.positions
    ego_from_world = [invert_transformation(m) for m in poses]
    pred = [X @ m[:3, :3].T + m[:3, 3] for m in ego_from_world]
    diff = np.linalg.norm(pred[0] - pred[1], axis=1)
    if max_range is not None:
        near = (np.linalg.norm(pred[0], axis=1) <= max_range) \
            & (np.linalg.norm(pred[1], axis=1) <= max_range)
        if near.any():
            diff = np.where(near, diff, -1.0)
    return int(np.argmax(diff))
