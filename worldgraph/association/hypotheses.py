"""Association hypotheses: a clique fitted (weighted Kabsch), checked for mirror matches,
scored by its robust fit cost over every percept, ranked and compared."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from perception import Percept

from .._checks import real_scalar
from .._rigid import rigid_transform
from ..errors import (
    WorldGraphError,
)
from ..model import WorldModel
from ..pose.frames import weighted_kabsch_batch
from ..pose.gravity import SearchKind
from ..tolerances import PLANAR_RTOL, TINY, AssociationTolerances, _check_tolerances, _resolved_tol


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
        Filled by :func:`~worldgraph.localize` on every hypothesis it returns: the projection
        of the hypothesis' Gaussian spheres (its clique and validated matches, one per distinct
        model position; centre = model object, radius = percept range, sigma) onto their
        restriction polytope, the paper's range-consistency score (its
        ``normalized_displacement``); None when those matches have fewer than two distinct
        model positions, and on hypotheses that did not come from ``localize``.
    search : {"gravity", "free"}
        The search that made it (:mod:`worldgraph.pose.gravity`): the storey-aware gravity search or
        the free 3D search.
    """

    pairs: tuple[tuple[int, int], ...]
    cost: float
    size: int
    world_from_ego: NDArray[np.float64] = field(default_factory=lambda: np.eye(4))
    validated: tuple[tuple[int, int], ...] = ()
    inliers: int = 0
    complete: bool = True
    radial: Any = None
    search: SearchKind = "free"

    @property
    def all_pairs(self) -> tuple[tuple[int, int], ...]:
        """``pairs`` and ``validated`` merged, sorted by percept index."""
        return tuple(sorted(self.pairs + self.validated))



# ----------------------------------------------------------------------------------------------
# chirality, fit cost, hypotheses
# ----------------------------------------------------------------------------------------------
def _cross(a: NDArray, b: NDArray) -> NDArray:
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


#: Point sets with at most this many tetrahedra (C(11, 4)) have every one tested by the mirror
#: check; larger sets test a bounded family of ``2 m - 3`` (see ``_tetrahedra``), so memory
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
    opposite sign (``_tetrahedra``: all of them up to 11 members, a linear-size family above).

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
        n1 = _cross(dw[:, :, 1], dw[:, :, 2])  # the normal of the face opposite vertex 1
        vw = np.sum(dw[:, :, 0] * n1, axis=-1)
        # std of 6V under isotropic point noise: |d(6V)/d point c| = twice the opposite face's
        # area; faces[c] is the normal of the face opposite vertex c, from the edges at vertex 0
        # (the face opposite vertex 0 from its own edges)
        s = sigmas[hh, quads]
        faces = (_cross(w[:, :, 2] - w[:, :, 1], w[:, :, 3] - w[:, :, 1]), n1,
                 _cross(dw[:, :, 0], dw[:, :, 2]), _cross(dw[:, :, 0], dw[:, :, 1]))
        var = np.zeros(ve.shape)
        for drop in range(4):
            area2 = np.linalg.norm(faces[drop], axis=-1)
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
        ne_full = _cross(e[:, :, 1] - e[:, :, 0], e[:, :, 2] - e[:, :, 0])
        ne = ne_full[..., 2]
        nw = _cross(w[:, :, 1] - w[:, :, 0], w[:, :, 2] - w[:, :, 0])[..., 2]
        s = sigmas[hh, tri].max(axis=2)
        span = np.max(np.linalg.norm(w - w[:, :, :1], axis=-1), axis=-1)
        gate = tol.chirality_sigmas * tol.pair_factor * 2.0 * s * span
        # a tilt of the ego z axis up to the allowance moves the normal's z by |n| sin(allowance)
        gate_e = gate + np.linalg.norm(ne_full, axis=-1) * math.sin(tol.tilt_allowance)
        bad = (np.abs(nw) > gate) & (np.abs(ne) > gate_e) & (np.sign(ne) != np.sign(nw))
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
    good = sv[:, 1] > PLANAR_RTOL * np.maximum(sv[:, 0], TINY)
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
    """:func:`same_pose` of checked transforms: ``_near_poses`` of one."""
    return bool(_near_poses(b, a[None, :3, 3], a[None, :3, :3], tol)[0])


def _near_poses(T: NDArray, translations: NDArray, rotations: NDArray, tol: AssociationTolerances
                ) -> NDArray[np.bool_]:
    """Which of the poses ``(translations (k, 3), rotations (k, 3, 3))`` are the same pose as
    ``T`` (4, 4) by :func:`same_pose`'s test (no checks; ``_rank`` runs it for every ranked
    hypothesis against every kept one); the angle as :func:`~worldgraph.pose.rotation_angle`."""
    near = np.sqrt(np.sum((translations - T[:3, 3]) ** 2, axis=1)) < tol.distinct_translation
    c = (np.sum(rotations * T[:3, :3], axis=(1, 2)) - 1.0) / 2.0  # trace(Ra^T Rb)
    return near & (np.arccos(np.clip(c, -1.0, 1.0)) < tol.distinct_angle)


def _rank(hyps: list[AssociationHypothesis], tol: AssociationTolerances, limit: int
          ) -> list[AssociationHypothesis]:
    """By cost; a hypothesis is merged into a cheaper one with the same pose unless they match
    some percept to different objects (a close percept matched to the neighbour of its object
    moves the pose only a little, but it is another hypothesis)."""
    hyps = sorted(hyps, key=lambda h: (h.cost, -h.size, h.pairs))
    kept: list[AssociationHypothesis] = []
    matched: list[dict[int, int]] = []
    # the kept poses' translations and rotations, for ``_near_poses`` against all at once
    t_kept = np.empty((min(limit, len(hyps)), 3))
    r_kept = np.empty((min(limit, len(hyps)), 3, 3))
    for h in hyps:
        mine = dict(h.all_pairs)
        n = len(kept)
        if n:
            near = _near_poses(h.world_from_ego, t_kept[:n], r_kept[:n], tol)
            if any(all(matched[g].get(p, o) == o for p, o in mine.items()) for g in np.flatnonzero(near)):
                continue
        matched.append(mine)
        t_kept[n], r_kept[n] = h.world_from_ego[:3, 3], h.world_from_ego[:3, :3]
        kept.append(h)
        if len(kept) >= limit:
            break
    return kept


def is_ambiguous(hypotheses: Sequence[AssociationHypothesis],
                 tol: AssociationTolerances | None = None) -> bool:
    """The best two hypotheses have costs within ``ambiguity_margin`` and poses that differ."""
    hypotheses = _check_hypotheses(hypotheses)
    tol = _resolved_tol(tol)
    if len(hypotheses) < 2:
        return False
    poses = [rigid_transform(f"hypotheses[{i}].world_from_ego", h.world_from_ego)
             for i, h in enumerate(hypotheses[:2])]
    costs = [real_scalar(f"hypotheses[{i}].cost", h.cost) for i, h in enumerate(hypotheses[:2])]
    return (costs[1] - costs[0] < tol.ambiguity_margin
            and not _same_pose(poses[0], poses[1], tol))



def _check_hypotheses(hypotheses: object) -> list[AssociationHypothesis]:
    if hypotheses is None or isinstance(hypotheses, str | bytes | AssociationHypothesis):
        raise WorldGraphError(f"hypotheses must be a sequence of AssociationHypothesis, "
                              f"got {type(hypotheses).__name__}")
    try:
        hyps = list(hypotheses)  # type: ignore[call-overload]
    except TypeError as exc:
        raise WorldGraphError(f"hypotheses must be a sequence of AssociationHypothesis, "
                              f"got {type(hypotheses).__name__}") from exc
    for i, h in enumerate(hyps):
        if not isinstance(h, AssociationHypothesis):
            raise WorldGraphError(f"hypotheses[{i}] must be an AssociationHypothesis, "
                                  f"got {type(h).__name__}")
    return hyps


