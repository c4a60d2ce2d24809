"""Percept fusion by mean shift with the Epanechnikov kernel (paper section 2.2, Fig. 4).

Raw percepts of one type are clustered by mean shift; the percepts converging to one mode
form its delineation set, which is melted into one fused percept. Sets with fewer than
``min_views`` raw views (stragglers, typically false percepts) are rejected.

With the Epanechnikov kernel the mean-shift step is the (weighted) mean of the points inside
the kernel's support (its shadow is the flat kernel), so each iteration is exact and the
procedure stops at a fixed point after finitely many steps. The support is bounded (the unit
ball in whitened coordinates), so the points inside it are found exactly by a k-d tree
(``scipy.spatial.cKDTree.query_ball_point``); memory is O(n + neighbour pairs of a chunk),
never an n x n array.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from .._checks import integer, real_array, real_scalar, spd
from ..errors import (
    PerceptionError,
    TooManyNeighboursError,
)
from ..tolerances import MEAN_SHIFT_TOL, QUERY_SLACK, TINY
from .percept import Percept

DEFAULT_BANDWIDTH = 0.1
"""Default kernel radius, metres."""

MERGE_RADIUS = 0.5
"""Converged points closer than this (in bandwidth units) belong to one mode."""

MAX_WHITENED = 1e150
"""Largest coordinate (in bandwidth units) the fusion accepts; beyond it squares overflow."""

SIGMA_RANGE = (1e-150, 1e150)
"""Percept sigmas (metres) fusion accepts: their variances must be normal floats."""

VARIANCE_RANGE = (1e-300, 1e300)
"""Largest covariance entry (m^2) of a percept or bandwidth matrix that fusion accepts."""

MAX_ITER_LIMIT = 1_000_000
"""Largest ``max_iter`` accepted."""

_PAIR_BUDGET = 2_000_000  # neighbour pairs held at once per chunk of mean-shift queries
_CROWDED = 256  # rows with more neighbours than this are summed in dense blocks per grid cell
MAX_KERNEL_PAIRS = 100_000_000
"""Most (point, neighbour) pairs one mean-shift run evaluates over all its iterations (about half a
minute of work at most); beyond it the bandwidth is too large for the points' density (thousands of
points inside one kernel) and :class:`TooManyNeighboursError` is raised instead of running for
hours (the exact kernel sums cost the square of the points in one kernel)."""
_AHEAD = 20
"""Iterations a mean-shift run is assumed to still need when it does not shrink: from the second
iteration on, the strided-sample estimate of the next iteration's pairs is multiplied by the
iterations the run still needs at the rate its cost shrank by in the last one (at most
``min(_AHEAD, max_iter) - k``; ``1 / (1 - r)`` when the cost fell by the factor ``r < 1``), and
the product must fit in what is left of :data:`MAX_KERNEL_PAIRS`.  A run that collapses onto its
modes (cost falling fast) goes on; one whose cost stays flat (thousands of points per kernel) is
refused after its first iteration instead of after many (docs/design.md#defaults)."""


def _bandwidth_factor(name: str, value: Any, d: int) -> NDArray[np.float64] | float:
    """Whitening factor of a bandwidth: the radius ``h`` (float) or the Cholesky factor ``L`` of ``H``."""
    H = real_array(name, value)
    if H.ndim == 0:
        h = real_scalar(name, value, positive=True)
        if not SIGMA_RANGE[0] <= h <= SIGMA_RANGE[1]:
            raise PerceptionError(f"{name} must lie in [{SIGMA_RANGE[0]:g}, {SIGMA_RANGE[1]:g}] "
                                  f"(length units), got {h!r}")
        return h
    if H.shape != (d, d):
        raise PerceptionError(f"{name} must be a scalar or shape ({d}, {d}), got shape {H.shape}")
    H = spd(name, H, d)
    top = float(np.max(np.abs(H)))
    if not VARIANCE_RANGE[0] <= top <= VARIANCE_RANGE[1]:
        raise PerceptionError(f"{name}: largest entry must lie in [{VARIANCE_RANGE[0]:g}, "
                              f"{VARIANCE_RANGE[1]:g}], got {top!r}")
    # numpy's stubs widen the float64 factor to floating[Any]
    return cast(NDArray[np.float64], np.linalg.cholesky(H))


def _whiten(X: NDArray[np.float64], L: NDArray[np.float64] | float) -> NDArray[np.float64]:
    with np.errstate(over="ignore", invalid="ignore"):
        if isinstance(L, float):
            return X / L
        return np.linalg.solve(L, X.T).T


def _sparse_sums(
    tree: cKDTree, Z: NDArray[np.float64], w: NDArray[np.float64], Y: NDArray[np.float64], radius: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Kernel sums for rows with few neighbours: per-row neighbour lists, chunked by pair count."""
    m, d = Y.shape
    num = np.zeros((m, d))
    den = np.zeros(m)
    counts = np.asarray(tree.query_ball_point(Y, radius * (1.0 + QUERY_SLACK), return_length=True))
    csum = np.cumsum(counts)
    start = 0
    while start < m:
        base = csum[start - 1] if start else 0
        stop = int(np.searchsorted(csum, base + _PAIR_BUDGET, side="right"))
        stop = min(max(stop, start + 1), m)
        # Y is 2-D, so one neighbour list per row (the stubs cannot tell the point count from the type)
        lists = cast(list[list[int]], tree.query_ball_point(Y[start:stop], radius * (1.0 + QUERY_SLACK)))
        lens = np.fromiter((len(lst) for lst in lists), dtype=np.int64, count=stop - start)
        if lens.sum():
            flat = np.concatenate([np.asarray(lst, dtype=np.int64) for lst in lists])
            owner = np.repeat(np.arange(stop - start), lens)
            d2 = np.sum((Y[start:stop][owner] - Z[flat]) ** 2, axis=1)
            wk = np.where(d2 < radius**2, w[flat], 0.0)
            den[start:stop] = np.bincount(owner, wk, minlength=stop - start)
            for k in range(d):
                num[start:stop, k] = np.bincount(owner, wk * Z[flat, k], minlength=stop - start)
        start = stop
    return num, den


def _dense_sums(
    tree: cKDTree, Z: NDArray[np.float64], w: NDArray[np.float64], Y: NDArray[np.float64], radius: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Kernel sums for rows in crowded regions: rows grouped by grid cell (side ``radius``); one
    candidate query per cell, then blocks of at most ``_PAIR_BUDGET`` row-candidate pairs."""
    m, d = Y.shape
    num = np.zeros((m, d))
    den = np.zeros(m)
    cells, inv = np.unique(np.floor(Y / radius), axis=0, return_inverse=True)
    inv = np.asarray(inv).reshape(-1)
    order = np.argsort(inv, kind="stable")
    bounds = np.searchsorted(inv[order], np.arange(len(cells) + 1))
    reach = radius * (0.5 * np.sqrt(d) + 1.0) * (1.0 + QUERY_SLACK)
    for g, cell in enumerate(cells):
        rows = order[bounds[g] : bounds[g + 1]]
        cand = np.asarray(tree.query_ball_point((cell + 0.5) * radius, reach), dtype=np.int64)
        if cand.size == 0:
            continue
        Zc, wc = Z[cand], w[cand]
        step = max(1, _PAIR_BUDGET // cand.size)
        for s in range(0, rows.size, step):
            r = rows[s : s + step]
            Yr = Y[r]
            d2 = (Yr[:, 0, None] - Zc[None, :, 0]) ** 2
            for k in range(1, d):
                d2 += (Yr[:, k, None] - Zc[None, :, k]) ** 2
            W = np.where(d2 < radius**2, wc[None, :], 0.0)
            num[r] = W @ Zc
            den[r] = W.sum(axis=1)
    return num, den


def _spend(budget: list[int], pairs: float, crowd: int, n: int) -> None:
    """Raise :class:`TooManyNeighboursError` when ``pairs`` exceed what is left of ``budget``."""
    if pairs > budget[0]:
        raise TooManyNeighboursError(
            f"points: mean shift would need more than {MAX_KERNEL_PAIRS:,} kernel pair evaluations ({n:,} "
            f"points, up to {crowd:,} of them inside one kernel); the bandwidth is too large for this "
            "density of points: lower it, or fuse the points in batches"
        )


def _neighbour_means(
    tree: cKDTree, Z: NDArray[np.float64], w: NDArray[np.float64], Y: NDArray[np.float64], radius: float,
    budget: list[int] | None = None, ahead: float = 1.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Weighted sums ``sum w_j Z_j`` and ``sum w_j`` over ``|Z_j - Y_i| < radius``, per row of ``Y``.

    Rows with few neighbours use per-row neighbour lists; rows with many (crowded regions, where
    Python lists would dominate) are grouped by grid cell and summed in numpy blocks. Either
    way at most about ``_PAIR_BUDGET`` pairs are held at once.  ``budget`` (a one-item list) is
    decreased by the pairs this call evaluates; :class:`TooManyNeighboursError` when it falls below
    zero, or when ``ahead`` iterations like this one (estimated from a strided sample) would.
    """
    m, d = Y.shape
    num = np.zeros((m, d))
    den = np.zeros(m)
    if m == 0:
        return num, den
    if budget is not None:  # a strided sample first: counting every pair is itself quadratic
        sample = np.asarray(tree.query_ball_point(Y[:: max(1, m // 256)], radius * (1.0 + QUERY_SLACK),
                                                  return_length=True))
        _spend(budget, float(sample.mean()) * m * ahead, int(sample.max()), tree.n)
    counts = np.asarray(tree.query_ball_point(Y, radius * (1.0 + QUERY_SLACK), return_length=True))
    if budget is not None:
        _spend(budget, float(counts.sum()), int(counts.max()), tree.n)
        budget[0] -= int(counts.sum())
    crowded = (counts > _CROWDED) & np.all(np.abs(Y) < 1e12 * radius, axis=1)
    for mask, fn in ((~crowded, _sparse_sums), (crowded, _dense_sums)):
        idx = np.flatnonzero(mask)
        if idx.size:
            num[idx], den[idx] = fn(tree, Z, w, Y[idx], radius)
    return num, den


def _first_rep_labels(Y: NDArray[np.float64], radius: float) -> NDArray[np.int64]:
    """Label of each point: the mode of the first earlier representative closer than ``radius``.

    Equivalent to scanning the points in order and joining the first (lowest-index)
    representative within ``radius`` or founding a new one; a new representative claims every
    later unclaimed point within ``radius`` (each claimed point's lowest-index rep in reach).
    """
    n = Y.shape[0]
    labels = np.full(n, -1, dtype=np.int64)
    tree = cKDTree(Y)
    k = 0
    for i in range(n):
        if labels[i] >= 0:
            continue
        labels[i] = k
        nb = np.asarray(tree.query_ball_point(Y[i], radius * (1.0 + QUERY_SLACK)), dtype=np.int64)
        if nb.size:
            near = nb[(nb > i) & (labels[nb] < 0)]
            near = near[np.sum((Y[near] - Y[i]) ** 2, axis=1) < radius**2]
            labels[near] = k
        k += 1
    return labels


def mean_shift_modes(
    points: ArrayLike,
    bandwidth: float | ArrayLike,
    weights: ArrayLike | None = None,
    *,
    max_iter: int = 100,
    tol: float = MEAN_SHIFT_TOL,
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Mean shift from every point with the Epanechnikov kernel of bandwidth matrix ``H``.

    A point ``y`` moves to the weighted mean of the points ``x`` with
    ``(x - y)^T H^-1 (x - y) < 1``; a float bandwidth ``h`` means ``H = h^2 I``. Points whose
    fixed points lie within ``MERGE_RADIUS`` (in ``H`` units) of a mode's first member (in
    input order) share that mode. The points inside the kernel are found with a k-d tree;
    memory grows linearly with the number of points (and neighbour pairs).

    Parameters
    ----------
    points : (n, d) float
        Finite, in length units (e.g. metres).
    bandwidth : float or (d, d) float
        Kernel radius (length units, in [1e-150, 1e150]) or SPD bandwidth matrix (length^2).
    weights : (n,) float, optional
        Positive finite point weights (default 1); only their ratios matter.
    max_iter : int
        Iteration limit per point, in [1, 1e6].
    tol : float
        A point has converged when it moves less than ``tol`` (bandwidth units), > 0.

    Returns
    -------
    modes : (m, d) float
        Mean of the fixed points of each mode's members, in order of first appearance.
    labels : (n,) int
        Mode index of each point.
    """
    X = real_array("points", points, (None, None))
    n, d = X.shape
    if d < 1:
        raise PerceptionError(f"points must have at least one column, got shape {X.shape}")
    L = _bandwidth_factor("bandwidth", bandwidth, d)
    if weights is None:
        w = np.ones(n)
    else:
        w = real_array("weights", weights)
        if w.shape != (n,):
            raise PerceptionError(
                f"weights must have one entry per row of points, shape ({n},), got shape {w.shape}"
            )
        bad = np.flatnonzero(w <= 0)
        if bad.size:
            raise PerceptionError(f"weights[{bad[0]}] must be > 0, got {w[bad[0]]!r}")
    max_iter = integer("max_iter", max_iter, minimum=1, maximum=MAX_ITER_LIMIT)
    tol = real_scalar("tol", tol, positive=True)
    if n == 0:
        return np.zeros((0, d)), np.zeros(0, dtype=np.int64)
    w = w / w.max()  # only ratios matter; keeps the weighted sums in range
    Z = _whiten(X, L)
    bad_rows = ~np.all(np.isfinite(Z) & (np.abs(Z) <= MAX_WHITENED), axis=1)
    if np.any(bad_rows):
        i = int(np.flatnonzero(bad_rows)[0])
        raise PerceptionError(
            f"points[{i}] = {X[i].tolist()} is more than {MAX_WHITENED:g} bandwidths from the origin "
            f"(bandwidth {bandwidth!r}); fusion would overflow"
        )
    tree = cKDTree(Z)
    Y = Z.copy()
    active = np.ones(n, dtype=bool)
    budget = [MAX_KERNEL_PAIRS]
    ahead, last_cost = 1.0, 0
    for it in range(max_iter):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        # Coincident positions (common once a cluster has collapsed) share one query.
        uniq, inv = np.unique(Y[idx], axis=0, return_inverse=True)
        inv = np.asarray(inv).reshape(-1)
        before = budget[0]
        num, den = _neighbour_means(tree, Z, w, uniq, 1.0, budget, ahead)
        cost = before - budget[0]
        left = max(1.0, float(min(_AHEAD, max_iter) - it - 1))
        ratio = cost / last_cost if last_cost > 0 else 1.0
        ahead = min(left, 1.0 / (1.0 - ratio)) if ratio < 1.0 else left
        last_cost = cost
        num, den = num[inv], den[inv]
        empty = den <= 0  # no point strictly inside the kernel: y is a fixed point
        with np.errstate(invalid="ignore", divide="ignore"):
            new = np.where(empty[:, None], Y[idx], num / np.where(empty, 1.0, den)[:, None])
        moved = np.linalg.norm(new - Y[idx], axis=1)
        Y[idx] = new
        active[idx[(moved < tol) | empty]] = False
    labels = _first_rep_labels(Y, MERGE_RADIUS)
    m = int(labels.max()) + 1
    counts = np.bincount(labels, minlength=m).astype(np.float64)
    modes_z = np.column_stack([np.bincount(labels, Y[:, k], minlength=m) for k in range(d)]) / counts[:, None]
    modes = modes_z * L if isinstance(L, float) else modes_z @ L.T
    return modes, labels


def _canonical_order(percepts: Sequence[Percept]) -> NDArray[np.int64]:
    pos = np.array([p.position for p in percepts]).reshape(-1, 3)
    sig = np.array([p.sigma for p in percepts])
    views = np.array([p.views for p in percepts])
    # np.lexsort sorts by the last key first.
    return np.lexsort((views, sig, pos[:, 2], pos[:, 1], pos[:, 0]))


def _shared_loadings(members: Sequence[Percept], S: NDArray[np.float64], info: NDArray[np.float64],
                     q0: float) -> tuple[tuple[tuple[int, NDArray[np.float64]], ...], NDArray[np.float64]]:
    """The fused percept's shared loadings ``L_v = sum over members of view v of W_i S_iv``
    (``W_i = (sum C^-1)^-1 C_i^-1`` the fusion weights) and, in units of ``q0``, the covariance
    that members sharing a view add to ``(sum C^-1)^-1``: ``sum_v (L_v L_v^T - sum_i w w^T)``."""
    if not any(p.shared for p in members):
        return (), np.zeros((3, 3))
    loads: dict[int, NDArray[np.float64]] = {}
    own = np.zeros((3, 3))
    for i, p in enumerate(members):
        W = S @ info[i]  # dimensionless: S and info are in units of q0 and 1 / q0
        for view, Si in p.shared:
            w = W @ Si
            loads[view] = loads[view] + w if view in loads else w
            own += w @ w.T
    shared = tuple(sorted(loads.items(), key=lambda kv: kv[0]))
    cross = sum((L @ L.T for _, L in shared), np.zeros((3, 3))) - own
    return shared, 0.5 * (cross + cross.T) / q0


def _melt(members: Sequence[Percept]) -> Percept:
    """One fused percept from a delineation set (inverse-information combination).

    Computed in scaled units (each covariance ``C_i = q_i A_i`` with ``q_i`` its largest
    entry, information relative to the most precise member), so that variances from 1e-300
    to 1e300 m^2 neither overflow nor underflow.
    """
    X = np.array([p.position for p in members])
    A = np.empty((len(members), 3, 3))
    q = np.empty(len(members))
    for i, p in enumerate(members):
        if p.covariance is None:
            q[i] = p.sigma**2
            A[i] = np.eye(3)
        else:
            q[i] = float(np.max(np.abs(p.covariance)))
            A[i] = p.covariance / q[i]
    q0 = float(q.min())
    with np.errstate(under="ignore"):
        rel = q0 / q  # in (0, 1]; a vanishing share contributes nothing
        info = np.linalg.inv(A) * rel[:, None, None]  # information in units of 1 / q0
    S = np.linalg.inv(info.sum(axis=0))  # covariance in units of q0
    x0 = X[int(np.argmin(q))]
    m = x0 + S @ np.einsum("kij,kj->i", info, X - x0)
    k = len(members)
    shared, cross = _shared_loadings(members, S, info, q0)
    factor = 1.0
    with np.errstate(over="ignore", invalid="ignore"):
        if k > 1:
            r = X - m
            chi2 = float(np.einsum("ki,kij,kj->", r, info, r)) / q0
            factor = max(1.0, chi2 / (3.0 * (k - 1)))
        S = (0.5 * (S + S.T) + cross) * (q0 * factor)
    shared = tuple((v, L * np.sqrt(factor)) for v, L in shared)
    scale = float(np.max(np.abs(m)))
    if scale > 0:
        u = m / scale
        u = u / np.linalg.norm(u)
        var = float(u @ S @ u)
    else:
        var = float(np.trace(S) / 3.0)
    if not (np.all(np.isfinite(m)) and np.all(np.isfinite(S)) and np.isfinite(var) and var > 0):
        raise PerceptionError(
            f"fusing {k} percepts of type {members[0].type!r} near {X[0].tolist()} overflows "
            f"(scatter factor {factor!r}, variance scale {q0!r} m^2); the positions are too far apart "
            "for their covariances"
        )
    views = int(sum(p.views for p in members))
    try:
        return Percept(members[0].type, m, float(np.sqrt(var)), covariance=S, views=views, shared=shared)
    except PerceptionError as exc:
        raise PerceptionError(
            f"fusing {k} percepts of type {members[0].type!r} near {X[0].tolist()} gives an invalid "
            f"percept: {exc}"
        ) from exc


def _check_percepts(percepts: Any) -> list[Percept]:
    what = f"percepts must be a sequence of Percept, got {type(percepts).__name__}"
    if percepts is None or isinstance(percepts, (str, bytes, Percept, Mapping)):
        raise PerceptionError(what)
    try:
        ps = list(percepts)
    except TypeError as exc:
        raise PerceptionError(what) from exc
    for i, p in enumerate(ps):
        if not isinstance(p, Percept):
            raise PerceptionError(f"percepts[{i}] must be a Percept, got {type(p).__name__}")
        if p.covariance is None:
            if not SIGMA_RANGE[0] <= p.sigma <= SIGMA_RANGE[1]:
                raise PerceptionError(
                    f"percepts[{i}].sigma must lie in [{SIGMA_RANGE[0]:g}, {SIGMA_RANGE[1]:g}] m for fusion "
                    f"(its square must be a normal float), got {p.sigma!r}"
                )
        else:
            top = float(np.max(np.abs(p.covariance)))
            if not VARIANCE_RANGE[0] <= top <= VARIANCE_RANGE[1]:
                raise PerceptionError(
                    f"percepts[{i}].covariance: largest entry must lie in [{VARIANCE_RANGE[0]:g}, "
                    f"{VARIANCE_RANGE[1]:g}] m^2 for fusion, got {top!r}"
                )
    return ps


#: Why :func:`fuse_percepts_report` left out a set of raw percepts.
FusionDropReason = Literal["too_few_views"]


@dataclass(frozen=True)
class FusionDrop:
    """A set of raw percepts (one mean-shift mode) that fusion left out.

    Attributes
    ----------
    type : str
    position : (3,) float
        The mean position of the set's raw percepts (ego frame).
    views : int
        The views the set holds.
    reason : FusionDropReason
        ``"too_few_views"``: fewer than ``min_views``.
    detail : str
    """

    type: str
    position: NDArray[np.float64]
    views: int
    reason: FusionDropReason
    detail: str


@dataclass(frozen=True)
class FusionReport:
    """What :func:`fuse_percepts_report` made of raw percepts.

    Attributes
    ----------
    percepts : tuple of Percept
        The fused percepts, as :func:`fuse_percepts` returns them.
    dropped : tuple of FusionDrop
        Every set of raw percepts that gave no fused percept, with its reason.
    """

    percepts: tuple[Percept, ...]
    dropped: tuple[FusionDrop, ...]


def fuse_percepts(
    percepts: Sequence[Percept],
    *,
    bandwidth: float | ArrayLike | Mapping[str, float | ArrayLike] | None = None,
    min_views: int = 2,
    max_iter: int = 100,
    tol: float = MEAN_SHIFT_TOL,
) -> list[Percept]:
    """Fuse raw percepts of several views into one percept per object (section 2.2).

    Per type, mean shift (:func:`mean_shift_modes`, Epanechnikov kernel, weights
    ``1 / sigma^2``) finds the modes; each mode's delineation set with at least ``min_views``
    raw views becomes one percept:

    - position: the inverse-covariance (information) weighted mean of the set (the
      ``1 / sigma^2``-weighted mean for isotropic percepts);
    - covariance: ``(sum C_i^-1)^-1``, inflated by ``chi^2 / dof`` when the set scatters more
      than its covariances explain (the Birge ratio), so inconsistent sets are not overconfident;
    - sigma: the standard deviation of the range, ``sqrt(u^T C u)`` with ``u`` the unit
      position vector;
    - views: the number of raw views in the set;
    - shared: per view, the fusion-weighted sum of the members' shared loadings (errors common to
      all percepts of one view, e.g. head encoders; see :class:`Percept`), so fused percepts that
      drew on one view stay correlated; members sharing a view add their cross-covariance.

    The percepts are sorted canonically first, so the result does not depend on their order.
    Memory grows linearly with the number of percepts (k-d tree neighbour queries).

    Parameters
    ----------
    percepts : sequence of Percept
        Sigmas in [1e-150, 1e150] m (covariance entries up to [1e-300, 1e300] m^2).
    bandwidth : float, (3, 3) float, or dict type -> float | (3, 3) float, optional
        Kernel radius in metres, or bandwidth matrix in m^2 (e.g. a scaled
        :func:`perception.class_bandwidth`); default ``DEFAULT_BANDWIDTH``. A dict must name
        every type present.
    min_views : int
        Smallest delineation set kept (>= 1).
    max_iter : int
        Mean-shift iteration limit, in [1, 1e6].
    tol : float
        Convergence threshold (bandwidth units), > 0.

    Returns
    -------
    list of Percept
        Sorted by type, then by position.  :func:`fuse_percepts_report` also says which sets
        of raw percepts were left out and why (objects seen in fewer than ``min_views`` views).

    Raises
    ------
    PerceptionError
        - ``bandwidth`` is a dict without an entry for a type present.
        - Any invalid argument (named with index and value), or a set that cannot be melted
          without overflow.
    """
    return list(fuse_percepts_report(percepts, bandwidth=bandwidth, min_views=min_views, max_iter=max_iter,
                                     tol=tol).percepts)


def fuse_percepts_report(
    percepts: Sequence[Percept],
    *,
    bandwidth: float | ArrayLike | Mapping[str, float | ArrayLike] | None = None,
    min_views: int = 2,
    max_iter: int = 100,
    tol: float = MEAN_SHIFT_TOL,
) -> FusionReport:
    """:func:`fuse_percepts`, with a report of what it left out.

    Parameters
    ----------
    percepts, bandwidth, min_views, max_iter, tol
        As for :func:`fuse_percepts`.

    Returns
    -------
    FusionReport
        The fused percepts and every set of raw percepts (a mean-shift mode) that gave none:
        its type, mean position, views and reason.

    Raises
    ------
    PerceptionError
        As :func:`fuse_percepts`.
    """
    ps = _check_percepts(percepts)
    min_views = integer("min_views", min_views, minimum=1)
    max_iter = integer("max_iter", max_iter, minimum=1, maximum=MAX_ITER_LIMIT)
    tol = real_scalar("tol", tol, positive=True)
    types = sorted({p.type for p in ps})
    if isinstance(bandwidth, Mapping):
        missing = [t for t in types if t not in bandwidth]
        if missing:
            raise PerceptionError(
                f"bandwidth has no entry for types {missing}; it has {sorted(map(repr, bandwidth))}"
            )
        H = {t: bandwidth[t] for t in types}
        for t in types:
            _bandwidth_factor(f"bandwidth[{t!r}]", H[t], 3)
    else:
        Hall = DEFAULT_BANDWIDTH if bandwidth is None else bandwidth
        _bandwidth_factor("bandwidth", Hall, 3)
        H = dict.fromkeys(types, Hall)
    fused: list[Percept] = []
    dropped: list[FusionDrop] = []
    for t in types:
        group = [p for p in ps if p.type == t]
        group = [group[i] for i in _canonical_order(group)]
        X = np.array([p.position for p in group])
        sig = np.array([p.sigma for p in group])
        with np.errstate(under="ignore"):
            w = np.maximum((sig.min() / sig) ** 2, TINY)  # 1 / sigma^2 up to a common factor
        name = "bandwidth" if not isinstance(bandwidth, Mapping) else f"bandwidth[{t!r}]"
        try:
            _, labels = mean_shift_modes(X, H[t], w, max_iter=max_iter, tol=tol)
        except PerceptionError as exc:
            raise type(exc)(f"percepts of type {t!r} with {name}: {exc}") from exc
        out = []
        for k in range(int(labels.max()) + 1):
            members = [group[i] for i in np.flatnonzero(labels == k)]
            views = sum(p.views for p in members)
            if views >= min_views:
                out.append(_melt(members))
            else:
                centre = np.mean([p.position for p in members], axis=0)
                dropped.append(FusionDrop(t, centre, views, "too_few_views",
                                          f"{views} view(s) of a {t!r} near {np.round(centre, 3).tolist()}, "
                                          f"fewer than min_views = {min_views}"))
        out = [out[i] for i in _canonical_order(out)] if out else []
        fused += out
    return FusionReport(tuple(fused), tuple(dropped))


#: Default number of standard deviations of :func:`percept_bandwidths`.
BANDWIDTH_SIGMAS = 3.0
#: Default smallest bandwidth of :func:`percept_bandwidths`, metres.
MIN_BANDWIDTH = 0.02


def percept_bandwidths(percepts: Sequence[Percept], *, n_sigma: float = BANDWIDTH_SIGMAS,
                       minimum: float = MIN_BANDWIDTH) -> dict[str, float]:
    """A mean-shift radius per type from the raw percepts' own uncertainty.

    Views of one object scatter by their errors; two objects of one type closer than the radius
    merge.  Per type: ``n_sigma`` times the median over its percepts of the largest standard
    deviation of the position (``sqrt`` of the covariance's largest eigenvalue, else ``sigma``),
    at least ``minimum``.  Four knobs 12 cm apart seen to 1 cm stay four (radius 3 cm); doors
    seen to 3 cm get 9 cm.

    Parameters
    ----------
    percepts : sequence of Percept
        The raw percepts :func:`fuse_percepts` will fuse.
    n_sigma : float
        > 0.
    minimum : float
        Smallest radius, metres, > 0.

    Returns
    -------
    dict of str to float
        For :func:`fuse_percepts`' ``bandwidth``; every type present.
    """
    ps = _check_percepts(percepts)
    n_sigma = real_scalar("n_sigma", n_sigma, positive=True, maximum=1e6)
    minimum = real_scalar("minimum", minimum, positive=True, maximum=1e6)
    spreads: dict[str, list[float]] = {}
    for p in ps:
        sd = p.sigma if p.covariance is None else float(np.sqrt(np.linalg.eigvalsh(p.covariance)[-1]))
        spreads.setdefault(p.type, []).append(sd)
    return {t: max(minimum, n_sigma * float(np.median(v))) for t, v in sorted(spreads.items())}
