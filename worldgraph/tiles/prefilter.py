"""Which tiles can answer a query: a summary of each tile (:class:`TileSummary`, small enough for an
index of a thousand tiles) and the pre-filter that visits only the tiles whose summary admits the
percepts (:func:`tiles_to_visit`).

A tile is skipped only when :func:`~worldgraph.localize` on it could not find a pose:

* ``"no_types"``: fewer than ``max(3, tol.min_clique_size)`` percepts have a type the tile holds
  (``localize`` would say ``"too_few_percepts"`` or raise ``WorldGraphError``);
* ``"no_consistent_triple"``: no three of those percepts are pairwise consistent with the tile's
  link lengths.  Every association of ``localize`` (the gravity search and the free search alike)
  keeps a percept pair only when its 3D length is within ``tol.pair_tolerance`` of the length of
  an object pair of the same types, and needs a clique of at least three; the summary keeps, per
  type pair, which bins of :data:`LINK_BIN` metres hold a link (object pairs up to
  ``max_link_length + link_margin``), and a percept pair is called consistent when a bin within
  its tolerance (widened by :data:`TOLERANCE_SLACK` and a bin) is occupied, or when it is longer
  than the links reach (those go to the far-pair search, which the summary does not model);
* ``"outside_prior"``: with a position prior ``near`` and ``radius`` (WiFi, GPS, the last pose),
  no object of the tile lies within ``radius`` plus the reach of the percepts (their largest range
  plus 3 sigma) of ``near``: the robot cannot see the tile from where the prior puts it.

The first two never skip a tile that holds the answer (the test visits every tile and checks that
each skipped one returns no pose); the third trusts the caller's prior.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from perception import Percept

from .. import _checks
from ..errors import WorldGraphError
from ..tolerances import AssociationTolerances, _resolved_tol
from .tiling import Tile

__all__ = ["LINK_BIN", "SKIP_REASONS", "TOLERANCE_SLACK", "SkipReason", "TileSummary", "TileVisit",
           "summarize", "tiles_to_visit"]

#: Width (m) of the link-length bins of a :class:`TileSummary`.
LINK_BIN = 0.05
#: The pre-filter widens every pair tolerance by this factor (and one bin): it must never be
#: stricter than the association it stands in for.
TOLERANCE_SLACK = 1.5
#: Why :func:`tiles_to_visit` skips a tile.
SkipReason = Literal["no_types", "no_consistent_triple", "outside_prior"]
SKIP_REASONS: tuple[SkipReason, ...] = ("no_types", "no_consistent_triple", "outside_prior")


@dataclass(frozen=True, eq=False)
class TileSummary:
    """What the pre-filter knows of one tile.

    Attributes
    ----------
    label : int
        The tile's label.
    n_objects : int
        Its objects (own and halo).
    lower, upper : (3,) float
        Bounds of its objects' positions (metres).
    type_counts : mapping str -> int
        Objects per type.
    reach : float
        ``max_link_length + link_margin`` of the tile's world: longer pairs are not binned.
    bin_width : float
        Metres per bin.
    link_bins : mapping (type a, type b) -> (m,) int
        Sorted indices ``floor(length / bin_width)`` of the bins that hold at least one link of the
        type pair (``a <= b``).
    """

    label: int
    n_objects: int
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    type_counts: Mapping[str, int]
    reach: float
    bin_width: float
    link_bins: Mapping[tuple[str, str], NDArray[np.int64]]


def summarize(tile: Tile, bin_width: float = LINK_BIN) -> TileSummary:
    """The :class:`TileSummary` of ``tile`` (from its world's link tables)."""
    if not isinstance(tile, Tile):
        raise WorldGraphError(f"tile must be a Tile (from worldgraph.tiles.tiling), "
                              f"got {_checks._short(tile)}")
    bin_width = _checks.real_scalar("bin_width", bin_width, positive=True)
    world = tile.world
    bins = {}
    for key, table in world.links.items():
        if len(table):
            bins[(min(key), max(key))] = np.unique(np.floor(table.length / bin_width).astype(np.int64))
    lower, upper = world.bounds
    counts = {t: int(len(idx)) for t, idx in world.type_index.items()}
    return TileSummary(tile.label, len(world), np.asarray(lower, dtype=np.float64),
                       np.asarray(upper, dtype=np.float64), counts,
                       float(world.max_link_length + world.link_margin), bin_width, bins)


@dataclass(frozen=True)
class TileVisit:
    """The pre-filter's word on one tile: visit it, or skip it and why."""

    label: int
    visit: bool
    reason: SkipReason | None = None
    detail: str = ""


def _consistent(summary: TileSummary, types: list[str], x: NDArray[np.float64], sig: NDArray[np.float64],
                tol: AssociationTolerances) -> NDArray[np.bool_]:
    """``(k, k)`` bool: which percept pairs a link of the tile could explain."""
    k = len(types)
    ok = np.zeros((k, k), dtype=bool)
    d = np.linalg.norm(x[:, None, :] - x[None, :, :], axis=2)
    tau = np.asarray(tol.pair_tolerance(sig[:, None], sig[None, :])) * TOLERANCE_SLACK + summary.bin_width
    for i in range(k):
        for j in range(i + 1, k):
            if d[i, j] + tau[i, j] >= summary.reach:
                ok[i, j] = True  # beyond the link tables: the far-pair search decides, not the summary
                continue
            key = (min(types[i], types[j]), max(types[i], types[j]))
            occupied = summary.link_bins.get(key)
            if occupied is None or not occupied.size:
                continue
            lo = math.floor(max(d[i, j] - tau[i, j], 0.0) / summary.bin_width)
            hi = math.floor((d[i, j] + tau[i, j]) / summary.bin_width)
            at = int(np.searchsorted(occupied, lo))
            ok[i, j] = at < occupied.size and int(occupied[at]) <= hi
    return ok | ok.T


def _has_triangle(adj: NDArray[np.bool_]) -> bool:
    a = adj.astype(np.int64)
    return bool(np.any((a @ a) * a))


def _box_distance(point: NDArray[np.float64], lower: NDArray[np.float64], upper: NDArray[np.float64]
                  ) -> float:
    return float(np.linalg.norm(np.maximum(np.maximum(lower - point, point - upper), 0.0)))


def tiles_to_visit(summaries: Sequence[TileSummary], percepts: Sequence[Percept], *,
                   tol: AssociationTolerances | None = None, near: ArrayLike | None = None,
                   radius: float | None = None) -> tuple[TileVisit, ...]:
    """Which of the tiles (their :class:`TileSummary`) can answer ``percepts`` (ego frame).

    Parameters
    ----------
    summaries : sequence of TileSummary
    percepts : sequence of perception.Percept
    tol : AssociationTolerances, optional
        The tolerances the query's :func:`~worldgraph.localize` uses (its pair
        tolerance and ``min_clique_size``).
    near : (3,) float, optional
        A position prior (world frame, metres): the robot stands within ``radius`` of it.
    radius : float, optional
        Metres, > 0; required with ``near``.

    Returns
    -------
    tuple of TileVisit
        One per summary, in order.
    """
    items = _checks.as_list("summaries", summaries, "TileSummary (from worldgraph.tiles.summarize)")
    for k, s in enumerate(items):
        if not isinstance(s, TileSummary):
            raise WorldGraphError(f"summaries[{k}] must be a TileSummary, got {_checks._short(s)}")
    plist = _checks.percept_list("percepts", percepts)
    tol = _resolved_tol(tol)
    prior = None
    if near is not None or radius is not None:
        if near is None or radius is None:
            raise WorldGraphError("near and radius go together: pass both (a position prior) or neither")
        prior = (_checks.real_array("near", near, (3,)), _checks.real_scalar("radius", radius, positive=True))
    need = max(3, int(tol.min_clique_size))
    x_all = np.array([p.position for p in plist], dtype=np.float64).reshape(-1, 3)
    sig_all = np.array([p.sigma for p in plist], dtype=np.float64)
    seen = float(np.max(np.linalg.norm(x_all, axis=1) + 3.0 * sig_all)) if len(plist) else 0.0
    out = []
    for s in items:
        known = [i for i, p in enumerate(plist) if p.type in s.type_counts]
        if len(known) < need:
            out.append(TileVisit(s.label, False, "no_types",
                                 f"{len(known)} percept(s) of its types, {need} needed"))
            continue
        if prior is not None:
            gap = _box_distance(prior[0], s.lower, s.upper)
            if gap > prior[1] + seen:
                out.append(TileVisit(s.label, False, "outside_prior", f"{gap:.3g} m from the prior position, "
                                     f"more than radius {prior[1]:g} m + the percepts' reach {seen:.3g} m"))
                continue
        adj = _consistent(s, [plist[i].type for i in known], x_all[known], sig_all[known], tol)
        if not _has_triangle(adj):
            out.append(TileVisit(s.label, False, "no_consistent_triple",
                                 "no three percepts pairwise consistent with the tile's link lengths"))
            continue
        out.append(TileVisit(s.label, True))
    return tuple(out)
