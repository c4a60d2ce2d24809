"""The range-only side of localisation: the Gaussian spheres of matched pairs
(:func:`match_spheres`), their radial projection (the design card's convex problem) and the
range-only position with its mirror candidates told apart."""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree
from scipy.stats import chi2

import radialopt as ro
from perception import Percept
from radialopt.projection import project_radii_unchecked

from .._checks import integer
from ..association.consistency import check_world_and_percepts
from ..errors import WorldGraphError
from ..model import WorldModel
from ..tolerances import DUPLICATE_DISTANCE, SIGNIFICANCE
from .context import _Context

#: Position candidates with at least this fraction of the best density are told apart by the
#: validated 3D pose.
CANDIDATE_DENSITY_RATIO = 0.01


def _distinct_centres(world: WorldModel, pairs: Sequence[tuple[int, int]]) -> tuple[tuple[int, int], ...]:
    """One pair per distinct model position (a sphere per centre): the first of the pairs whose
    objects lie within 1e-9 m of each other (a k-d tree, not all pairs)."""
    pairs = list(pairs)
    if len(pairs) < 2:
        return tuple(sorted(pairs))
    pos = world.positions[np.array([o for _, o in pairs], dtype=np.intp)]
    keep = np.ones(len(pairs), dtype=bool)
    for i, j in sorted(cKDTree(pos).query_pairs(DUPLICATE_DISTANCE)):
        if keep[i]:
            keep[j] = False
    return tuple(sorted(p for p, k in zip(pairs, keep, strict=True) if k))


def match_spheres(world: WorldModel, percepts: Sequence[Percept], pairs: Sequence[tuple[int, int]]
                  ) -> tuple[NDArray[np.intp], NDArray[np.intp], list[ro.GaussianSphere]]:
    """The Gaussian spheres of matched pairs ``(percept index, object index)``: one per distinct
    model position (centre = object, radius = percept range, sigma = percept sigma), sorted by
    percept; with the percept and object index of each."""
    percepts = check_world_and_percepts(world, percepts)
    return _match_spheres(world, percepts, _check_pairs(pairs, len(percepts), len(world)))


def _match_spheres(world: WorldModel, percepts: Sequence[Percept], pairs: Sequence[tuple[int, int]]
                   ) -> tuple[NDArray[np.intp], NDArray[np.intp], list[ro.GaussianSphere]]:
    sph = _distinct_centres(world, pairs)
    p_i = np.array([p for p, _ in sph], dtype=np.intp)
    o_i = np.array([o for _, o in sph], dtype=np.intp)
    spheres = ro.make_spheres(world.positions[o_i], [percepts[p].range for p in p_i],
                              [percepts[p].sigma for p in p_i]) if len(sph) else []
    return p_i, o_i, spheres


#: Most spheres radialopt's restriction polytope (active set, range-only estimators) and its
#: cvxpy formulation accept; localize keeps the most certain ones beyond that.
MAX_RADIAL_SPHERES = int(getattr(getattr(ro, "polytope", None), "MAX_POLYTOPE_SPHERES", 128))
MAX_CVXPY_SPHERES = int(getattr(getattr(ro, "formulation", None), "MAX_SPHERES", 64))


def _most_certain(ctx: _Context, p_i: NDArray[np.intp], o_i: NDArray[np.intp], spheres: list, limit: int
                  ) -> tuple[NDArray[np.intp], NDArray[np.intp], list]:
    """At most ``limit`` spheres: the smallest sigmas (ties by percept index), in percept order."""
    if len(spheres) <= limit:
        return p_i, o_i, spheres
    sig = np.array([ctx.used[p].sigma for p in p_i])
    keep = np.sort(np.lexsort((p_i, sig))[:limit])
    note = (f"{len(spheres)} matched spheres: the {limit} most certain are used for the range-only "
            "computations (radialopt's limit)")
    if note not in ctx.notes:
        ctx.notes.append(note)
    return p_i[keep], o_i[keep], [spheres[i] for i in keep]


def _check_pairs(pairs: object, n_percepts: int, n_objects: int) -> list[tuple[int, int]]:
    """``(percept, object)`` index pairs in range."""
    if pairs is None or isinstance(pairs, str | bytes):
        raise WorldGraphError(f"pairs must be a sequence of (percept, object) index pairs, got {pairs!r}")
    out = []
    try:
        items = list(pairs)  # type: ignore[call-overload]
    except TypeError as exc:
        raise WorldGraphError("pairs must be a sequence of (percept, object) index pairs, "
                              f"got {pairs!r}") from exc
    for i, pair in enumerate(items):
        try:
            p, o = pair
        except (TypeError, ValueError) as exc:
            raise WorldGraphError(f"pairs[{i}] must be a (percept, object) index pair, "
                                  f"got {pair!r}") from exc
        p = integer(f"pairs[{i}][0]", p, minimum=0, maximum=n_percepts - 1)
        o = integer(f"pairs[{i}][1]", o, minimum=0, maximum=n_objects - 1)
        out.append((p, o))
    return out


def _radial(ctx: _Context, pairs: Sequence[tuple[int, int]], check: bool | None = None
            ) -> ro.RadialSolution | None:
    """:func:`radialopt.project_radii` of the spheres of ``pairs`` (as :func:`match_spheres` makes
    them) with the solver asked for; None with fewer than two spheres.

    ``check`` (default: the call's ``check``) verifies the answer against vertex enumeration up
    to ``radialopt.MAX_VERTEX_SPHERES`` spheres.  The world and the percepts were checked on
    entry (:func:`check_world_and_percepts`), so the spheres' arrays go to radialopt's unchecked
    route (``radialopt.projection.project_radii_unchecked``): the same answer as
    ``project_radii(match_spheres(...)[2], ...)`` without validating them again per hypothesis.
    """
    sph = _distinct_centres(ctx.world, pairs)
    if len(sph) < 2:
        return None
    p_i = np.array([p for p, _ in sph], dtype=np.intp)
    o_i = np.array([o for _, o in sph], dtype=np.intp)
    limit = MAX_RADIAL_SPHERES if ctx.settings.solver == "active_set" else MAX_CVXPY_SPHERES
    p_i, o_i, _ = _most_certain(ctx, p_i, o_i, list(sph), limit)
    check = ctx.settings.check if check is None else check
    if check and len(p_i) > ro.MAX_VERTEX_SPHERES:  # enumeration would take minutes
        check = False
        note = (f"the vertex-enumeration check ran only on hypotheses of at most {ro.MAX_VERTEX_SPHERES} "
                "spheres (radialopt.MAX_VERTEX_SPHERES); larger ones were solved unchecked")
        if note not in ctx.notes:
            ctx.notes.append(note)
    centers, radii, sigmas = ctx.world.positions[o_i], ctx.ranges[p_i], ctx.sigmas[p_i]
    if ctx.settings.solver == "active_set":
        return project_radii_unchecked(centers, radii, sigmas, method="active_set", check=check)
    return project_radii_unchecked(centers, radii, sigmas, method="cvxpy", solver=ctx.settings.solver,
                                   check=check)


def _radial_score(sol: ro.RadialSolution | None) -> float:
    """Minus twice the log density kept by the radial projection (0 when the ranges meet)."""
    return 0.0 if sol is None else float(sol.normalized_displacement) ** 2


def _range_consistent(sol: ro.RadialSolution | None, alpha: float = SIGNIFICANCE) -> bool:
    """The radial displacement is within the ``1 - alpha`` chi-square gate (n degrees of freedom)."""
    return sol is None or _radial_score(sol) <= float(chi2.ppf(1.0 - alpha, len(sol.radii)))


def _sphere_position(ctx: _Context, pairs: tuple[tuple[int, int], ...], estimator: str, t_ref: NDArray,
                     rng: np.random.Generator | None) -> tuple:
    """One Gaussian sphere per distinct matched centre and the range-only position.

    Returns the percepts used, the centres, sigmas, the estimate, the chosen position (mirror
    candidates told apart by ``t_ref``), its status and its CRLB.
    """
    t0 = time.perf_counter()
    sp, o_i, spheres = _match_spheres(ctx.world, ctx.used, pairs)
    sp, o_i, spheres = _most_certain(ctx, sp, o_i, spheres, MAX_RADIAL_SPHERES)
    centers = ctx.world.positions[o_i]
    sig = np.array([ctx.used[p].sigma for p in sp])
    est = ro.estimate_position(spheres, method=estimator, region=ctx.region, rng=rng)
    ctx.timings["position"] = time.perf_counter() - t0
    position, status = _choose_candidate(ctx, est, t_ref)
    return sp, centers, sig, est, position, status, _position_covariance(est, position, centers, sig)


def _position_covariance(est: ro.PositionEstimate, position: NDArray, centers: NDArray, sig: NDArray
                         ) -> NDArray[np.float64]:
    """The range-only CRLB at the chosen candidate (the estimator's own when it is its estimate)."""
    if np.array_equal(position, est.position):
        return est.covariance
    try:
        return ro.crlb(centers, sig, position)
    except ro.RadialError:
        return np.full((3, 3), np.inf)


def _choose_candidate(ctx: _Context, est: ro.PositionEstimate, t_ref: NDArray) -> tuple[NDArray, str]:
    """The range-only position, its mirror ambiguity resolved by the 3D pose ``t_ref``."""
    position = est.position
    if est.status in ("too_few_spheres", "degenerate_collinear") or not np.all(np.isfinite(position)):
        return position, "degenerate_collinear" if est.status == "degenerate_collinear" else "degenerate"
    cands = np.asarray(est.candidates, dtype=np.float64).reshape(-1, 3)
    dens = np.asarray(est.candidate_density, dtype=np.float64).reshape(-1)
    status = est.status
    if len(cands) > 1 and len(dens) == len(cands):
        close = cands[dens >= CANDIDATE_DENSITY_RATIO * dens.max()] if dens.max() > 0 else cands
        d = np.linalg.norm(close - t_ref, axis=1)
        order = np.argsort(d)
        if len(close) == 1 or d[order[0]] < 0.5 * d[order[1]]:
            if not np.array_equal(close[order[0]], position):
                ctx.notes.append("position candidate chosen by the validated 3D pose (mirror ambiguity)")
            position = close[order[0]]
            if status == "ambiguous":
                status = "ok"
    if status == "outside_region" and not ctx.explicit_region:
        status = "ok"
    if status != "ok":
        ctx.notes.append(est.message)
    return position, status
