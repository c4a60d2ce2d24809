"""The typed consistency graph of the association: input checks, candidate model pairs of
each percept pair (link tables, the far-pair index, k-d trees), lazy far pairs and pruning."""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from perception import Percept

from .._checks import percept_list
from ..errors import (
    WorldGraphError,
)
from ..model import FAR_PAIR_HEIGHT, FAR_PAIR_RANGE, FarPairIndex, WorldModel, ring_join
from ..pose.gravity import tilt_widening
from ..tolerances import FAR_PAIR_SLACK, QUERY_FLOOR, QUERY_WIDEN, AssociationTolerances

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
        raise WorldGraphError(f"world must be a WorldModel, got {type(world).__name__}")
    if len(world) == 0:
        raise WorldGraphError("the world model has no objects")
    return check_percepts(percepts)


def check_percepts(percepts: Sequence[Percept], name: str = "percepts") -> list[Percept]:
    """A sequence of Percepts whose scales the fits can handle, as a list.

    Raises :class:`~worldgraph.errors.WorldGraphError` naming ``name`` or ``name[i]`` (the index
    of a wrong element, its sigma, position or covariance scale).
    """
    percepts = percept_list(name, percepts)
    lo, hi = SIGMA_RANGE
    if not percepts:
        return percepts
    # one vectorised pass (a Percept is already validated: finite, SPD); loops only to name
    sig = np.array([float(p.sigma) for p in percepts])
    bad = np.flatnonzero(~((sig >= lo) & (sig <= hi)))
    if bad.size:
        k = int(bad[0])
        raise WorldGraphError(f"{name}[{k}].sigma = {sig[k]:.3g} m is outside [{lo:g}, {hi:g}] m, the "
                              "range the association and pose fits can handle (covariance scale "
                              f"{sig[k] ** 2:.3g} m^2)")
    pos = np.array([p.position for p in percepts], dtype=np.float64)
    bad = np.flatnonzero(~np.all(np.abs(pos) <= MAX_COORDINATE, axis=1))
    if bad.size:
        k = int(bad[0])
        raise WorldGraphError(f"{name}[{k}].position = {pos[k].tolist()} exceeds {MAX_COORDINATE:g} m")
    with_cov = [k for k, p in enumerate(percepts) if p.covariance is not None]
    if with_cov:
        ev = np.linalg.eigvalsh(np.array([percepts[k].covariance for k in with_cov], dtype=np.float64))
        bad = np.flatnonzero(~((ev[:, 0] >= lo * lo) & (ev[:, -1] <= hi * hi)))
        if bad.size:
            k, e = with_cov[int(bad[0])], ev[int(bad[0])]
            raise WorldGraphError(f"{name}[{k}].covariance has eigenvalues {e[0]:.3g}..{e[-1]:.3g} "
                                  f"m^2, outside [{lo * lo:g}, {hi * hi:g}] m^2 (the range the fits "
                                  "can handle)")
    return percepts


def _check_inputs(world: WorldModel, percepts: Sequence[Percept]) -> list[Percept]:
    percepts = check_world_and_percepts(world, percepts)
    for k, p in enumerate(percepts):
        if p.type not in world.type_index:
            raise WorldGraphError(f"percepts[{k}] has type {p.type!r}, which is not in the world model; "
                                  f"known types: {world._known_types()}")
    return percepts


@dataclass(frozen=True)
class _SupportIndex:
    """Edges of a ``_Graph`` for vectorised pruning: global vertex ids ``u``/``v`` (vertex
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
        ``_prune`` (which runs once per clique size tried)."""
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
                tol: AssociationTolerances) -> tuple[NDArray[np.float64], float, float, float, float, bool]:
    """``(diff, d, htol, ztol, reach, covered)`` of the percept pair: the offset from p to q and
    its length; gravity-aligned, the tolerances of the horizontal length and of the height
    difference (``tau`` and the height tolerance, each widened by what a tilt of
    ``tol.tilt_allowance`` can change, :func:`~worldgraph.pose.gravity.tilt_widening`); how far a
    model distance may differ from ``d`` (``tau`` in both searches: a rotation keeps lengths,
    so the gravity search tests the 3D length too, which cuts the widened gates down to the
    model pairs a tilt can explain); and whether the link table holds every pair within reach."""
    diff = percepts[q].position - percepts[p].position
    d = float(np.linalg.norm(diff))
    ztol = tau if tol.height_tolerance is None else float(tol.height_tolerance)
    htol = tau
    if tol.gravity_aligned:
        wide_h, wide_z = tilt_widening(math.hypot(diff[0], diff[1]), float(diff[2]), tol.tilt_allowance)
        htol, ztol = tau + float(wide_h), ztol + float(wide_z)
    reach = tau
    return diff, d, htol, ztol, reach, d + reach < world.max_link_length + world.link_margin


def _far_index(world: WorldModel, tp: str, tq: str, diff: NDArray[np.float64], d: float, ztol: float,
               tau: float, reach: float, tol: AssociationTolerances) -> tuple[FarPairIndex, bool] | None:
    """The world's far-pair index of the two types when it covers the percept pair's window, and
    whether it is kept as (tq, tp) (see ``WorldModel._far_pair_index``)."""
    if tol.gravity_aligned:
        if math.hypot(diff[0], diff[1]) + tau >= FAR_PAIR_RANGE or abs(diff[2]) + ztol >= FAR_PAIR_HEIGHT:
            return None
    elif d + reach >= FAR_PAIR_RANGE:
        return None
    index, flip = world._far_pair_index(tp, tq, bool(tol.gravity_aligned), lazy=True)
    return None if index is None else (index, flip)


def _index_window(index: FarPairIndex, diff: NDArray[np.float64], d: float, tau: float, reach: float
                  ) -> tuple[slice, float, float]:
    """``(window, centre, half)``: the index pairs whose key is within ``half`` of ``centre``
    (gravity-aligned: the horizontal distance within ``tau``, else the distance within ``reach``)."""
    centre, half = (math.hypot(diff[0], diff[1]), tau) if index.dz is not None else (d, reach)
    return index.window(centre - half, centre + half), centre, half


def _raised_query(world: WorldModel, objs: NDArray[np.intp], tq: str, diff: NDArray[np.float64], tau: float,
                  ztol: float) -> tuple[NDArray[np.float64], cKDTree, float]:
    """Gravity-aligned k-d tree query beyond the link table: ``objs``' positions raised by dz,
    q's tree, both with z scaled by :data:`GRAVITY_Z_SCALE`, and the radius (not widened) that
    holds every partner on the horizontal ring of radius h, thin in z."""
    s = GRAVITY_Z_SCALE
    pts = (world.positions[objs] + [0.0, 0.0, diff[2]]) * [1.0, 1.0, s]
    return pts, world.type_tree(tq, s), _raised_radius(math.hypot(diff[0], diff[1]), tau, ztol)


def _raised_radius(h: float, tau: float, ztol: float) -> float:
    """The radius, in coordinates with z scaled by :data:`GRAVITY_Z_SCALE`, of the ball that
    holds the horizontal ring of radius ``h`` (+- ``tau``) and height band (+- ``ztol``)."""
    return math.hypot(h + tau, GRAVITY_Z_SCALE * ztol)


def _indexed_candidates(world: WorldModel, found: tuple[FarPairIndex, bool], diff: NDArray[np.float64],
                        d: float, ztol: float, tau: float, reach: float, sub: NDArray[np.intp] | None,
                        sub_q: NDArray[np.intp] | None = None) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Far percept pair candidates from the world's far-pair index: the pairs in the key window
    (3D distance, or gravity-aligned horizontal distance and dz) whose p object is in ``sub``
    (all when None) and whose q object is in ``sub_q`` (all when None), tested exactly as the
    other branches of ``_pair_candidates`` do.  The float32 keys are within
    :data:`FAR_PAIR_SLACK` of the float64 values, so pairs that pass by more than the slack pass
    the exact test and only the pairs near the edge are computed again from the positions.
    An index kept as (q's type, p's type) is read as the pair (q, p), offset ``-diff``."""
    index, flip = found
    if flip:
        qs, ps = _indexed_candidates(world, (index, False), -diff, d, ztol, tau, reach, sub_q, sub)
        return ps, qs
    h = math.hypot(diff[0], diff[1])
    gravity = index.dz is not None
    w, centre, half = _index_window(index, diff, d, tau, reach)
    i, j, key = index.i[w], index.j[w], index.key[w]
    keep = np.ones(len(i), dtype=bool)
    if sub is not None:
        keep &= _members(world, sub)[i]
    if sub_q is not None:
        keep &= _members(world, sub_q)[j]
    off = np.abs(key - centre)
    inner = off < half - FAR_PAIR_SLACK
    if index.dz is not None:
        dzw = index.dz[w]
        offz = np.abs(dzw - diff[2])
        keep &= offz < ztol + FAR_PAIR_SLACK
        inner &= offz < ztol - FAR_PAIR_SLACK
        # the 3D length (a tilt keeps it), from the float32 key and dz: within 2 slacks of the truth
        off3 = np.abs(np.hypot(key.astype(np.float64), dzw) - d)
        keep &= off3 < reach + 2.0 * FAR_PAIR_SLACK
        inner &= off3 < reach - 2.0 * FAR_PAIR_SLACK
    edge = np.flatnonzero(keep & ~inner)
    if edge.size:  # the exact tests of _pair_candidates, in float64 from the positions
        dv = world.positions[j[edge]] - world.positions[i[edge]]
        if gravity:
            ok = (np.abs(dv[:, 2] - diff[2]) < ztol) & (np.abs(np.hypot(dv[:, 0], dv[:, 1]) - h) < tau) & \
                (np.abs(np.linalg.norm(dv, axis=1) - d) < reach)
        else:
            ok = np.abs(np.linalg.norm(dv, axis=1) - d) < reach
        keep[edge[~ok]] = False
    return i[keep].astype(np.intp), j[keep].astype(np.intp)


def _members(world: WorldModel, idx: NDArray[np.intp]) -> NDArray[np.bool_]:
    """A mask over the world's objects that is True at ``idx``."""
    mask = np.zeros(len(world), dtype=bool)
    mask[idx] = True
    return mask


#: Far pairs beyond the far-pair index between more than this many object pairs go through the
#: compiled ring join (:mod:`worldgraph.model.ring_join`, against the types' kept grids) when numba is
#: installed (the ``fast`` extra); smaller ones, and every one without numba, through the k-d
#: trees of ``_tree_pairs``, which give the same pairs (the tests run both).  ``None`` turns
#: the ring join off.  Below 1M pairs the k-d trees are cheap and numba is not loaded
#: (docs/design.md#defaults).
RING_JOIN_MIN_PAIRS: int | None = 1_000_000


def _use_ring_join(sub: NDArray[np.intp], sub_q: NDArray[np.intp]) -> bool:
    return (RING_JOIN_MIN_PAIRS is not None and ring_join.HAVE_NUMBA
            and len(sub) * len(sub_q) > RING_JOIN_MIN_PAIRS)


def _ring_candidates(world: WorldModel, types: tuple[str, str],
                     full: tuple[NDArray[np.intp], NDArray[np.intp]],
                     chosen: tuple[NDArray[np.intp], NDArray[np.intp]], ring: tuple[float, float],
                     band: tuple[float, float]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Every pair ``(i, j)`` (global indices, ``i != j``) of the chosen objects of the two types
    whose horizontal distance lies in ``ring`` and height offset ``z_j - z_i`` in ``band``: the
    smaller side's objects against the larger side's kept :meth:`WorldModel.type_grid` (its
    objects that are not chosen masked out), through the compiled kernel."""
    swap = len(chosen[0]) > len(chosen[1])
    side = 0 if swap else 1  # the grid's side
    rows = chosen[1 - side]
    grid_full, grid_chosen = full[side], chosen[side]
    mask = None if len(grid_chosen) == len(grid_full) else _members(world, grid_chosen)[grid_full]
    lo, hi = (-band[1], -band[0]) if swap else band  # z_i - z_j when the grid holds i's side
    r, g = ring_join.ring_pairs_in(world.positions[rows], world.type_grid(types[side]), h_lo=ring[0],
                                   h_hi=ring[1], z_lo=lo, z_hi=hi, b_mask=mask)
    a, b = rows[r], grid_full[g]
    i, j = (b, a) if swap else (a, b)
    keep = i != j
    return i[keep], j[keep]


#: A far pair's k-d tree query uses a tree of one side's chosen objects (built for the call)
#: instead of the type's kept tree when they are at most this fraction of the type.
SUBTREE_FRACTION = 0.5


def _tree_pairs(world: WorldModel, types: tuple[str, str], full: tuple[NDArray[np.intp], NDArray[np.intp]],
                chosen: tuple[NDArray[np.intp], NDArray[np.intp]], dz: float, z_scale: float,
                shell: tuple[float, float]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Every pair ``(i, j)`` (global indices) of the chosen objects of the two types (``chosen``,
    subsets of the types' objects ``full``) whose offset minus ``(0, 0, dz)``, with z multiplied
    by ``z_scale``, has a length within ``shell = (lo, hi)``: one dual k-d tree query in C.

    Each side is queried through its type's kept tree (:meth:`WorldModel.type_tree`; pairs of
    objects not chosen are then dropped) when it holds more than :data:`SUBTREE_FRACTION` of its
    type, else through a tree of its chosen objects built for the call; ``dz`` moves a built
    tree (when both sides are large, the smaller is built), so a side of a few objects against
    a type of 200k builds no large tree."""
    (tp, tq), (op, oq), (sub, sub_q) = types, full, chosen
    own_p = len(sub) <= SUBTREE_FRACTION * len(op)
    own_q = len(sub_q) <= SUBTREE_FRACTION * len(oq)
    if dz != 0.0 and not (own_p or own_q):
        own_p, own_q = len(sub) <= len(sub_q), len(sub) > len(sub_q)
    scale = np.array([1.0, 1.0, z_scale])
    lift = np.array([0.0, 0.0, dz])
    tree_p = cKDTree((world.positions[sub] + lift) * scale) if own_p else world.type_tree(tp, z_scale)
    lift = lift if not own_p else 0.0 * lift  # dz moves one side only
    tree_q = cKDTree((world.positions[sub_q] - lift) * scale) if own_q else world.type_tree(tq, z_scale)
    pairs = tree_p.sparse_distance_matrix(tree_q, shell[1], output_type="ndarray")
    pairs = pairs[pairs["v"] >= shell[0]]
    i, j = (sub if own_p else op)[pairs["i"]], (sub_q if own_q else oq)[pairs["j"]]
    keep = i != j
    if not own_p and len(sub) < len(op):
        keep &= _members(world, sub)[i]
    if not own_q and len(sub_q) < len(oq):
        keep &= _members(world, sub_q)[j]
    return i[keep], j[keep]


def _pair_candidates(world: WorldModel, percepts: list[Percept], p: int, q: int, tau: float,
                     tol: AssociationTolerances, objects: list[NDArray[np.intp]],
                     rows: NDArray[np.intp] | None = None, cols: NDArray[np.intp] | None = None,
                     ) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Model pairs consistent with the percept pair (p, q): local indices ``(a, b)`` into
    ``objects[p]`` and ``objects[q]``.  ``rows`` and ``cols`` (local indices into ``objects[p]``
    and ``objects[q]``; used for far pairs, see ``_is_far``) restrict p's and q's side to
    those objects."""
    tp, tq = percepts[p].type, percepts[q].type
    op, oq = objects[p], objects[q]
    diff, d, tau, ztol, reach, covered = _pair_reach(world, percepts, p, q, tau, tol)
    sub = op if rows is None else op[rows]
    sub_q = oq if cols is None else oq[cols]
    i: NDArray[np.integer]  # intp from the link tables and trees, int32 from the far-pair index
    j: NDArray[np.integer]
    if covered:
        lo, hi = d - reach, d + reach
        if tol.gravity_aligned:
            # |h_m - h| < tau and |dz_m - dz| < ztol bound the 3D length too: the window is the
            # tighter of the two (the 3D test below keeps |d_m - d| < reach)
            h, adz = math.hypot(diff[0], diff[1]), abs(float(diff[2]))
            box_lo = math.hypot(max(h - tau, 0.0), max(adz - ztol, 0.0)) * (1.0 - QUERY_WIDEN) - QUERY_FLOOR
            box_hi = math.hypot(h + tau, adz + ztol) * (1.0 + QUERY_WIDEN) + QUERY_FLOOR
            lo, hi = max(lo, box_lo), min(hi, box_hi)
        i, j, _ = world.link_lengths(tp, tq, lo, hi)
        if tp == tq:
            i, j = np.concatenate([i, j]), np.concatenate([j, i])
        if rows is not None:
            keep = _members(world, sub)[i]
            i, j = i[keep], j[keep]
        if cols is not None:
            keep = _members(world, sub_q)[j]
            i, j = i[keep], j[keep]
    elif len(op) * len(oq) <= tol.dense_pair_limit:
        ii, jj = np.meshgrid(sub, sub_q, indexing="ij")
        i, j = ii.ravel(), jj.ravel()
        dm = np.linalg.norm(world.positions[j] - world.positions[i], axis=1)
        keep = (np.abs(dm - d) < reach) & (i != j)
        i, j = i[keep], j[keep]
    elif (found := _far_index(world, tp, tq, diff, d, ztol, tau, reach, tol)) is not None:
        # the far-pair index applies the final tests itself
        i, j = _indexed_candidates(world, found, diff, d, ztol, tau, reach, sub if rows is not None else None,
                                   sub_q if cols is not None else None)
        return _renumber(world, tp, tq, op, oq, i, j)
    elif tol.gravity_aligned:
        # beyond the link table, z up: p's objects raised by dz (or q's lowered), both with z
        # scaled by GRAVITY_Z_SCALE: the partners lie on a horizontal ring of radius h, thin in
        # z, and the other storeys far outside the query radius; the gravity test below is exact
        h = math.hypot(diff[0], diff[1])
        if _use_ring_join(sub, sub_q):  # the compiled ring join: only the ring's cells are visited
            dz, zwide = float(diff[2]), (abs(float(diff[2])) + ztol) * QUERY_WIDEN + QUERY_FLOOR
            i, j = _ring_candidates(world, (tp, tq), (op, oq), (sub, sub_q),
                                    (max(0.0, (h - tau) * (1.0 - QUERY_WIDEN)),
                                     (h + tau) * (1.0 + QUERY_WIDEN) + QUERY_FLOOR),
                                    (dz - ztol - zwide, dz + ztol + zwide))
        else:
            radius = _raised_radius(h, tau, ztol) * (1.0 + QUERY_WIDEN) + QUERY_FLOOR
            i, j = _tree_pairs(world, (tp, tq), (op, oq), (sub, sub_q), float(diff[2]), GRAVITY_Z_SCALE,
                               ((h - tau) * (1.0 - QUERY_WIDEN), radius))
    else:
        # beyond the link table: the two types' k-d trees give every pair within d + reach
        # (dual tree, in C); the shell |d_model - d| < reach, with the distances computed as in
        # the other branches, keeps the candidates
        wide = reach * (1.0 + QUERY_WIDEN) + QUERY_FLOOR
        if _use_ring_join(sub, sub_q):  # the compiled shell join
            ii, jj = ring_join.shell_pairs(world.positions[sub], world.positions[sub_q],
                                           r_lo=max(0.0, d - wide), r_hi=d + wide)
            i, j = sub[ii], sub_q[jj]
            keep = i != j
            i, j = i[keep], j[keep]
        else:
            i, j = _tree_pairs(world, (tp, tq), (op, oq), (sub, sub_q), 0.0, 1.0, (d - wide, d + wide))
        dm = np.linalg.norm(world.positions[j] - world.positions[i], axis=1)
        keep = np.abs(dm - d) < reach
        i, j = i[keep], j[keep]
    if tol.gravity_aligned and len(i):
        dv = world.positions[j] - world.positions[i]
        keep = (np.abs(dv[:, 2] - diff[2]) < ztol) & \
            (np.abs(np.hypot(dv[:, 0], dv[:, 1]) - math.hypot(diff[0], diff[1])) < tau) & \
            (np.abs(np.linalg.norm(dv, axis=1) - d) < reach)
        i, j = i[keep], j[keep]
    return _renumber(world, tp, tq, op, oq, i, j)


def _renumber(world: WorldModel, tp: str, tq: str, op: NDArray[np.intp], oq: NDArray[np.intp],
              i: NDArray[np.integer], j: NDArray[np.integer]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Global object indices ``i`` (of ``op``) and ``j`` (of ``oq``) as local indices."""
    if op is world.type_index[tp] and oq is world.type_index[tq]:  # the usual case: a gather
        rank = world.type_rank
        return rank[i], rank[j]
    return _local(op, i), _local(oq, j)


#: The far pairs of ``_LazyGraph`` are filled in rounds, cheapest first: each round takes the
#: pairs with at most this many times the rows of the cheapest (counted as at least
#: ``FAR_ROUND_MIN_ROWS``), then prunes.
FAR_ROUND_FACTOR = 2
FAR_ROUND_MIN_ROWS = 64


#: Rows sampled to estimate how many model pairs one row's far-pair query visits.
FAR_COST_SAMPLE = 32


def _far_hits_per_row(world: WorldModel, percepts: list[Percept], p: int, q: int, tau: float,
                      tol: AssociationTolerances, objects: list[NDArray[np.intp]]) -> float:
    """About how many model pairs the far-pair query of one of p's objects visits (at least 1):
    the index window's pairs per p object, or the k-d tree hits of an even sample of p's objects
    (the disk of ``_pair_candidates``, which keeps only its shell)."""
    tp, tq = percepts[p].type, percepts[q].type
    diff, d, tau, ztol, reach, _ = _pair_reach(world, percepts, p, q, tau, tol)
    op = objects[p]
    if (found := _far_index(world, tp, tq, diff, d, ztol, tau, reach, tol)) is not None:
        w, _, _ = _index_window(found[0], diff, d, tau, reach)
        return max(1.0, (w.stop - w.start) / max(len(op), 1))
    pick = op[np.unique(np.linspace(0, len(op) - 1, min(len(op), FAR_COST_SAMPLE)).astype(np.intp))]
    if tol.gravity_aligned:
        pts, tree, radius = _raised_query(world, pick, tq, diff, tau, ztol)
    else:
        pts, radius, tree = world.positions[pick], d + reach, world.type_tree(tq)
    return max(1.0, float(np.mean(tree.query_ball_point(pts, radius, return_length=True))))


@dataclass
class _FarPair:
    """What ``_LazyGraph`` has queried of one far percept pair (p, q): ``done`` marks the
    rows (p's local indices) queried, each against (at least) the q objects ``covered`` marks;
    ``parts`` holds the candidates found; ``repeated`` says that some of them may be found twice
    (a row queried again against revived q objects)."""

    tau: float
    hits: float  # the model pairs one row's query visits (``_far_hits_per_row``)
    done: NDArray[np.bool_]
    covered: NDArray[np.bool_]
    parts: list[tuple[NDArray[np.intp], NDArray[np.intp]]] = field(default_factory=list)
    repeated: bool = False

    def complete(self, alive_p: NDArray[np.bool_], alive_q: NDArray[np.bool_]) -> bool:
        """Every alive row is queried against every alive q object."""
        return not (np.any(alive_p & ~self.done) or np.any(alive_q & ~self.covered))


class _LazyGraph:
    """The consistency graph with the far percept pairs (``_is_far``) filled on demand.

    Pruning for a clique size ``need`` first treats every far pair as unconstrained; that keeps a
    superset of the vertices the exact pruning keeps (pruning is monotone in the edges).  The far
    pairs' candidates are then computed between those vertices only (p's alive rows against q's
    alive objects; later calls add the vertices a smaller ``need`` revives), and the graph of the
    near pairs plus the far candidates found so far is pruned again: exactly, because every
    vertex it can keep has all its far candidates among the vertices it can keep (edges to
    vertices the pruning has already removed cannot support anything).  Far pairs cost queries
    between the few objects that fit the near pairs, not between all objects of their types.
    """

    def __init__(self, world: WorldModel, percepts: list[Percept], tol: AssociationTolerances) -> None:
        self.world, self.percepts, self.tol = world, percepts, tol
        self.objects = [world.type_index[p.type] for p in percepts]
        sig = np.array([p.sigma for p in percepts])
        self.near: dict[tuple[int, int], tuple[NDArray[np.intp], NDArray[np.intp]]] = {}
        self.far: dict[tuple[int, int], _FarPair] = {}
        for p, q in itertools.combinations(range(len(percepts)), 2):
            tau = float(tol.pair_tolerance(sig[p], sig[q]))
            if _is_far(world, percepts, p, q, tau, tol, self.objects):
                hits = _far_hits_per_row(world, percepts, p, q, tau, tol, self.objects)
                self.far[(p, q)] = _FarPair(tau, hits, np.zeros(len(self.objects[p]), dtype=bool),
                                            np.zeros(len(self.objects[q]), dtype=bool))
            else:
                self.near[(p, q)] = _pair_candidates(world, percepts, p, q, tau, tol, self.objects)
        self.free = _Graph(self.objects, {**self.near, **dict.fromkeys(self.far)})

    def prune(self, need: int) -> tuple[_Graph, list[NDArray[np.bool_]]]:
        """A graph whose pruning for ``need`` (or any larger size) equals the full graph's, and
        that pruning.

        Far pairs are filled in rounds, the cheapest first (rows to query times the model pairs a
        row's query visits, ``_far_hits_per_row``, times the alive fraction of q's objects:
        on the 1M campus the cost order cut the associate median by a fifth against rows alone),
        and the graph is pruned again after each round: a far pair counts as unconstrained until
        every alive vertex of its p side is queried against every alive vertex of its q side, and
        as constrained from then on, so every intermediate pruning keeps a superset of the exact
        one (see the class docstring) while the rows left to query shrink with each constraint
        added."""
        if not self.far:
            return self.free, _prune(self.free, need)
        graph = self._current()
        alive = _prune(graph, need)
        while True:
            # a pair's cost: its rows to query (again, for revived q objects) times the model
            # pairs one row's query visits among q's alive objects
            pending = []
            for key, far in self.far.items():
                p, q = key
                n = np.count_nonzero(alive[p] & ~far.done)
                if np.any(alive[q] & ~far.covered):
                    n += np.count_nonzero(alive[p] & far.done)
                if n:
                    frac = np.count_nonzero(alive[q]) / max(len(alive[q]), 1)
                    pending.append((n * far.hits * frac, key))
            if not pending:
                # every far pair is queried between all alive vertices: constrain them all
                final = self._current(alive)
                return final, _prune(final, need, alive)
            pending.sort()
            # this round: the cheapest pairs, up to FAR_ROUND_FACTOR times the cheapest one's cost
            floor = FAR_ROUND_MIN_ROWS * self.far[pending[0][1]].hits
            limit = FAR_ROUND_FACTOR * max(pending[0][0], floor)
            for cost, (p, q) in pending:
                if cost > limit:
                    break
                self._query(p, q, alive)
            graph = self._current(alive)
            alive = _prune(graph, need, alive)

    def _query(self, p: int, q: int, alive: list[NDArray[np.bool_]]) -> None:
        """Query the far pair (p, q) between the alive vertices: the queried rows that are still
        alive against the revived q objects, then the new rows against q's alive objects."""
        far = self.far[(p, q)]
        query = functools.partial(_pair_candidates, self.world, self.percepts, p, q, far.tau, self.tol,
                                  self.objects)
        if np.any(far.done & ~alive[p]):  # a row removed now is queried again (in full) if it revives
            far.done &= alive[p]
            far.repeated = True
        revived = alive[q] & ~far.covered
        if revived.any() and far.done.any():
            far.parts.append(query(np.flatnonzero(far.done), np.flatnonzero(revived)))
            far.repeated = True
        # every queried row now covers q's alive objects (and maybe more)
        far.covered = alive[q].copy()
        todo = np.flatnonzero(alive[p] & ~far.done)
        if todo.size:
            far.parts.append(query(todo, np.flatnonzero(alive[q])))
            far.done[todo] = True

    def _current(self, alive: list[NDArray[np.bool_]] | None = None) -> _Graph:
        """The near pairs plus the far pairs queried between every alive vertex (``alive``
        None: every vertex); the other far pairs unconstrained."""
        edges: dict[tuple[int, int], tuple[NDArray[np.intp], NDArray[np.intp]] | None] = dict(self.near)
        for (p, q), far in self.far.items():
            if alive is None:
                complete = bool(far.done.all() and far.covered.all())
            else:
                complete = far.complete(alive[p], alive[q])
            if far.parts and complete:
                a = np.concatenate([x for x, _ in far.parts])
                b = np.concatenate([y for _, y in far.parts])
                if far.repeated:  # one edge per pair (a row queried twice may find one twice)
                    code = np.unique(a.astype(np.int64) * len(far.covered) + b)
                    a, b = code // len(far.covered), code % len(far.covered)
                    far.parts, far.repeated = [(a, b)], False
                edges[(p, q)] = (a, b)
            else:
                edges[(p, q)] = None
        return _Graph(self.objects, dict(sorted(edges.items())))


def _consistency_graph(world: WorldModel, percepts: list[Percept], tol: AssociationTolerances) -> _Graph:
    objects = [world.type_index[p.type] for p in percepts]
    sig = np.array([p.sigma for p in percepts])
    edges: dict[tuple[int, int], tuple[NDArray[np.intp], NDArray[np.intp]] | None] = {}
    for p, q in itertools.combinations(range(len(percepts)), 2):
        tau = float(tol.pair_tolerance(sig[p], sig[q]))
        edges[(p, q)] = _pair_candidates(world, percepts, p, q, tau, tol, objects)
    return _Graph(objects, edges)


#: ``_prune`` loops over the part pairs up to this many pairs (16 percepts) and works on all
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
    """``_prune`` with a loop over the part pairs; each pair's edges shrink to the alive ones."""
    k = len(graph.objects)
    cur = [np.ones(len(o), dtype=bool) for o in graph.objects] if alive is None else [a.copy() for a in alive]
    edges = dict(graph.edges)
    count = np.min_scalar_type(k)  # supports count parts: small integers keep the arrays in cache

    def add(support: NDArray[np.integer], ends: NDArray[np.intp]) -> None:
        # one support for each distinct vertex among the edge ends (a mask: sorting the ends
        # was slower even when they were few against the part)
        hit = np.zeros(len(support), dtype=bool)
        hit[ends] = True
        support += hit

    while True:
        free = np.zeros(k, dtype=np.int64)  # supports of the unconstrained pairs, per part
        support = [np.zeros(len(a), dtype=count) for a in cur]
        has = [bool(a.any()) for a in cur]
        for (p, q), e in edges.items():
            if e is None:
                free[p] += has[q]
                free[q] += has[p]
                continue
            a, b = e
            keep = cur[p][a] & cur[q][b]
            a, b = a[keep], b[keep]
            edges[(p, q)] = (a, b)
            add(support[p], a)
            add(support[q], b)
        changed = False
        for p in range(k):
            new = cur[p] & (support[p] >= need - 1 - int(free[p]))
            if np.count_nonzero(new) != np.count_nonzero(cur[p]):
                cur[p], changed = new, True
        if not changed:
            return cur


def _prune_vectorised(graph: _Graph, need: int, start: list[NDArray[np.bool_]] | None = None
                      ) -> list[NDArray[np.bool_]]:
    """``_prune`` over all edges at once (see ``_Graph.support_index``)."""
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


