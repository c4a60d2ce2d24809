"""Global self-localisation: association -> Gaussian spheres -> position -> orientation.

:func:`localize` runs the whole pipeline of the paper (sections 2.2-2.3, 4) on fused percepts:

1. association (:func:`worldgraph.association.associate`; ``method="paper"`` uses the paper's
   proximity and orientation filters, every other method the typed consistency-graph cliques);
2. ``method="ml"`` (default): the maximum-likelihood 6D pose of the matched percepts from
   their full 3D positions and covariances (Gauss-Newton on SE(3) from the hypothesis' Kabsch
   pose), with the Cramer-Rao bound of the position; the steps below are the range-only
   methods (``"spheres"``, ``"paper"``, ``"srls"``, ``"gradient"``):
3. for the best hypothesis, one Gaussian sphere per matched pair: centre = model object
   position, radius = ``|percept position|``, sigma = percept sigma, and
   ``radialopt.estimate_position`` (the sphere estimator of the method) inside ``region`` (default
   ``world.region(REGION_MARGIN)``); when the landmarks are coplanar the estimator cannot tell
   a candidate from its mirror image, and the hypothesis' Kabsch pose (which uses the full 3D percepts)
   picks the candidate;
4. orientation (``"paper"``: eq. 5, ``S_model S_percept^-1`` of the best-conditioned matched
   triple; the other range-only methods): the proper rotation R minimising
   ``sum w_p |R x_p - (X_o - t)|^2``, ``w_p = 1 / (sigma_p^2 + var_t)``, with the translation
   fixed to the estimated position t and ``var_t`` a third of the trace of its covariance
   (1/sigma^2 alone lets one close percept dominate and leaves the rotation about its
   direction free).

Percepts whose type the world does not have are ignored (named in the result's message);
when no percept type is known, :class:`~worldgraph.errors.UnknownTypeError` is raised.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

import radialopt as ro
from perception import Percept

from .association import (
    ASSOCIATION_TOLERANCES,
    AssociationHypothesis,
    AssociationTolerances,
    associate,
    check_world_and_percepts,
    is_ambiguous,
)
from .errors import UnknownTypeError, WorldGraphError
from .model import WorldModel
from .pose import percept_frame, pose_from_frames, refine_pose, transformation, weighted_rotation

__all__ = ["LOCALIZE_METHODS", "LOCALIZE_STATUSES", "REGION_MARGIN", "LocalizationResult", "localize"]

#: ``"ml"``: the maximum-likelihood 6D pose from the full 3D percepts (their covariances);
#: ``"spheres"``: the range-only maximum-likelihood position of the Gaussian spheres
#: (``radialopt`` method ``"ml"``), then the rotation; ``"paper"``: the paper's association and
#: its radial-projection position; ``"srls"``, ``"gradient"``: other range-only estimators.
LOCALIZE_METHODS = ("ml", "spheres", "paper", "srls", "gradient")
#: Range-only position estimator of ``radialopt.estimate_position`` behind each method.
_SPHERE_ESTIMATOR = {"spheres": "ml", "paper": "paper", "srls": "srls", "gradient": "gradient"}
#: Default region: ``world.region(REGION_MARGIN)`` (metres beyond the objects in x, y and up).
REGION_MARGIN = 1.0
#: Position candidates with at least this fraction of the best density are told apart by the
#: association's 3D (Kabsch) pose.
CANDIDATE_DENSITY_RATIO = 0.01

#: Statuses of :class:`LocalizationResult`.  Position statuses of radialopt
#: (``"outside_region"``, ``"degenerate_coplanar"``, ``"degenerate_collinear"``) pass through.
LOCALIZE_STATUSES = (
    "ok",                    # a unique pose
    "ambiguous",             # another association or position candidate is about as good
    "no_association",        # no consistent set of >= 3 percept-object pairs
    "too_few_percepts",      # fewer than 3 percepts of known types
    "degenerate",            # the matched landmarks cannot fix a pose (collinear, ...)
    "outside_region",
    "degenerate_coplanar",
    "degenerate_collinear",
)


@dataclass(frozen=True)
class LocalizationResult:
    """Result of :func:`localize`.

    Attributes
    ----------
    transformation : (4, 4) float
        ``world_from_ego``; NaN everywhere when no pose could be determined.
    position : (3,) float
        Robot (ego origin) position in the world, ``transformation[:3, 3]``.
    covariance : (3, 3) float
        Cramer-Rao bound of the position (inf when unobservable, NaN when no pose).
    correspondences : tuple of (percept_index, object_index)
        Indices into the ``percepts`` passed in and into ``world.objects``.
    hypotheses : tuple of AssociationHypothesis
        Ranked; percept indices refer to the ``percepts`` passed in.
    ambiguous : bool
    status : str
        One of :data:`LOCALIZE_STATUSES`.
    message : str
    timings : dict str -> float
        Seconds per stage: ``"association"``, ``"position"``, ``"orientation"``, ``"total"``.
    position_estimate : radialopt.PositionEstimate or None
    """

    transformation: NDArray[np.float64]
    position: NDArray[np.float64]
    covariance: NDArray[np.float64]
    correspondences: tuple[tuple[int, int], ...]
    hypotheses: tuple[AssociationHypothesis, ...]
    ambiguous: bool
    status: str
    message: str = ""
    timings: dict[str, float] = field(default_factory=dict)
    position_estimate: ro.PositionEstimate | None = None


def _failed(status: str, message: str, hyps: tuple = (), timings: dict | None = None,
            ambiguous: bool = False) -> LocalizationResult:
    nan3 = np.full(3, np.nan)
    return LocalizationResult(np.full((4, 4), np.nan), nan3, np.full((3, 3), np.nan), (), hyps,
                              ambiguous, status, message, timings or {})


def _remap(h: AssociationHypothesis, idx: NDArray[np.intp]) -> AssociationHypothesis:
    return AssociationHypothesis(
        pairs=tuple((int(idx[p]), o) for p, o in h.pairs), cost=h.cost, size=h.size,
        world_from_ego=h.world_from_ego, validated=tuple((int(idx[p]), o) for p, o in h.validated),
        inliers=h.inliers)


def localize(world: WorldModel, percepts: Sequence[Percept], method: str = "ml", *,
             tolerances: AssociationTolerances | None = None, region: ro.Region | None = None,
             rng: np.random.Generator | None = None) -> LocalizationResult:
    """Pose of the robot (``world_from_ego``) from percepts of known world objects.

    Parameters
    ----------
    world : WorldModel
    percepts : sequence of perception.Percept
        Fused percepts in the ego frame.
    method : {"ml", "spheres", "paper", "srls", "gradient"}
        ``"ml"`` (default): the maximum-likelihood 6D pose of the matched percepts, using their
        full 3D positions and covariances (:func:`~worldgraph.pose.refine_pose`; weighted
        Kabsch for isotropic percepts), covariance = the Cramer-Rao bound of the position.
        ``"spheres"``: the range-only ML position of the Gaussian spheres (``radialopt``
        ``"ml"``), then the rotation; right when the percept directions are unreliable
        (space-to-ego errors rotate percepts about the ego origin, ranges survive them).
        ``"paper"``: the paper's proximity + orientation filters and its radial-projection
        position; ``"srls"``, ``"gradient"``: other range-only estimators, for comparison.
    tolerances : AssociationTolerances, optional
    region : radialopt.Region, optional
        Valid robot positions; default ``world.region(REGION_MARGIN)`` (above the lowest
        object, at most a metre beyond the objects sideways and above).
    rng : numpy.random.Generator, optional
        Passed to the position estimator (extra random seeds).

    Returns
    -------
    LocalizationResult
        Never a silently wrong pose: when the association is ambiguous the status says so
        (the best pose is still returned); when no pose can be determined it is NaN.

    Raises
    ------
    EmptyWorldError
        The world has no objects.
    UnknownTypeError
        Percepts were given but none has a type of the world.
    WorldGraphError
        Unknown method, or something other than Percepts.
    """
    t_start = time.perf_counter()
    if method not in LOCALIZE_METHODS:
        raise WorldGraphError(f"unknown localize method {method!r}; choose one of {LOCALIZE_METHODS}")
    percepts = check_world_and_percepts(world, percepts)
    tol = ASSOCIATION_TOLERANCES if tolerances is None else tolerances
    if not isinstance(tol, AssociationTolerances):
        raise WorldGraphError(f"tolerances must be AssociationTolerances, got {type(tol).__name__}")

    known = np.array([p.type in world.type_index for p in percepts], dtype=bool)
    unknown = sorted({p.type for p, ok in zip(percepts, known, strict=True) if not ok})
    if percepts and not known.any():
        raise UnknownTypeError(f"no percept type is in the world model: percept types {unknown}, "
                               f"world types {list(world.type_index)}")
    notes = [f"ignored {int((~known).sum())} percept(s) of unknown type(s) {unknown}"] if unknown else []
    idx = np.flatnonzero(known)
    used = [percepts[i] for i in idx]
    if len(used) < max(3, tol.min_clique_size):
        return _failed("too_few_percepts", "; ".join(notes + [
            f"localisation needs at least {max(3, tol.min_clique_size)} percepts of known types, "
            f"got {len(used)}"]), timings={"association": 0.0, "position": 0.0, "orientation": 0.0,
                                          "total": time.perf_counter() - t_start})

    t0 = time.perf_counter()
    hyps_local = associate(world, used, tol, method="paper" if method == "paper" else "clique")
    t_assoc = time.perf_counter() - t0
    hyps = tuple(_remap(h, idx) for h in hyps_local)
    timings = {"association": t_assoc, "position": 0.0, "orientation": 0.0}
    if not hyps:
        timings["total"] = time.perf_counter() - t_start
        return _failed("no_association", "; ".join(notes + [
            "no consistent association of >= 3 percepts with the world model"]), timings=timings)
    ambiguous = is_ambiguous(hyps, tol)
    if not hyps[0].complete:
        ambiguous = True
        notes.append("clique search truncated (max_nodes/max_cliques): the world repeats itself "
                     "around these percepts, other associations may be as good")
    best = hyps[0]
    # one sphere per distinct centre: clique pairs first, then validated ones
    pairs_list: list[tuple[int, int]] = []
    for p, o in best.pairs + best.validated:
        x = world.positions[o]
        if all(np.linalg.norm(world.positions[q] - x) > 1e-9 for _, q in pairs_list):
            pairs_list.append((p, o))
    pairs = tuple(sorted(pairs_list))
    pi = np.array([p for p, _ in pairs])
    oi = np.array([o for _, o in pairs])
    ego = np.array([percepts[p].position for p in pi])
    sig = np.array([percepts[p].sigma for p in pi])
    centers = world.positions[oi]

    status = "ambiguous" if ambiguous else "ok"
    if ambiguous and len(hyps) > 1:
        second = hyps[1]
        gap = float(np.linalg.norm(second.world_from_ego[:3, 3] - best.world_from_ego[:3, 3]))
        notes.append(f"association ambiguous: best cost {best.cost:.3g}, next {second.cost:.3g} "
                     f"at a pose {gap:.3g} m away")
    reg = world.region(margin=REGION_MARGIN) if region is None else region
    if method == "ml":
        covs = np.array([percepts[p].covariance if percepts[p].covariance is not None
                         else percepts[p].sigma ** 2 * np.eye(3) for p in pi])
        return _ml_pose(ego, centers, covs, best.world_from_ego, reg, pairs, hyps, ambiguous, status,
                        notes, timings, t_start)

    t0 = time.perf_counter()
    spheres = ro.make_spheres(centers, np.linalg.norm(ego, axis=1), sig)
    est = ro.estimate_position(spheres, method=_SPHERE_ESTIMATOR[method], region=reg, rng=rng)
    timings["position"] = time.perf_counter() - t0
    position = est.position
    if est.status in ("too_few_spheres", "degenerate_collinear") or not np.all(np.isfinite(position)):
        timings["total"] = time.perf_counter() - t_start
        return _failed("degenerate_collinear" if est.status == "degenerate_collinear" else "degenerate",
                       "; ".join(notes + [est.message or "the matched landmarks fix no position"]),
                       hyps, timings, ambiguous)
    # The Kabsch pose of the hypothesis uses the full 3D percepts, ranges alone do not: among
    # the estimator's candidates of comparable density (mirror images across a near-plane of
    # landmarks) take the one nearest to it.
    t_h = best.world_from_ego[:3, 3]
    cands = np.asarray(est.candidates, dtype=np.float64).reshape(-1, 3)
    dens = np.asarray(est.candidate_density, dtype=np.float64).reshape(-1)
    est_status = est.status
    if len(cands) > 1 and len(dens) == len(cands):
        close = cands[dens >= CANDIDATE_DENSITY_RATIO * dens.max()] if dens.max() > 0 else cands
        d = np.linalg.norm(close - t_h, axis=1)
        order = np.argsort(d)
        if len(close) == 1 or d[order[0]] < 0.5 * d[order[1]]:
            if not np.array_equal(close[order[0]], position):
                notes.append("position candidate chosen by the association's 3D pose (mirror ambiguity)")
            position = close[order[0]]
            if est_status == "ambiguous":  # the 3D pose has resolved it
                est_status = "ok"
    if est_status == "ambiguous":
        status = "ambiguous"
        notes.append(est.message)
    elif est_status != "ok":
        status = est_status if status == "ok" else status
        notes.append(est.message)

    t0 = time.perf_counter()
    cov = est.covariance
    if not np.array_equal(position, est.position):
        try:
            cov = ro.crlb(centers, sig, position)
        except ro.RadialError:
            cov = np.full((3, 3), np.inf)
    if method == "paper":  # eq. 5: S_ego = S_model S_percept^-1 from the best-conditioned triple
        rot = _eq5_rotation(ego, centers, sig)
    else:
        # residual of R x_p - (X_o - t): percept noise plus the (common) position error
        pos_var = float(np.trace(cov)) / 3.0 if np.all(np.isfinite(cov)) else float(np.max(sig) ** 2)
        rot = weighted_rotation(ego, centers - position, 1.0 / (sig**2 + pos_var))
    timings["orientation"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - t_start
    return LocalizationResult(
        transformation=transformation(rot, position), position=np.array(position, dtype=np.float64),
        covariance=cov, correspondences=pairs, hypotheses=hyps, ambiguous=ambiguous or status == "ambiguous",
        status=status, message="; ".join(n for n in notes if n), timings=timings, position_estimate=est)


def _eq5_rotation(ego: NDArray, centers: NDArray, sigmas: NDArray, limit: int = 10) -> NDArray:
    """Rotation of eq. 5 from the matched triple whose model triangle has the largest area,
    among the ``limit`` most certain matches."""
    pool = np.sort(np.argsort(sigmas, kind="stable")[:limit])
    triples = np.array(list(itertools.combinations(pool.tolist(), 3)))
    a, b, c = (centers[triples[:, i]] for i in range(3))
    best = triples[int(np.argmax(np.linalg.norm(np.cross(b - a, c - a), axis=1)))]
    model = percept_frame(*centers[best])
    seen = percept_frame(*ego[best])
    return pose_from_frames(model, seen)[:3, :3]


def _ml_pose(ego: NDArray, centers: NDArray, covs: NDArray, start: NDArray, reg: ro.Region,
             pairs: tuple[tuple[int, int], ...], hyps: tuple, ambiguous: bool, status: str,
             notes: list[str], timings: dict[str, float], t_start: float) -> LocalizationResult:
    """The maximum-likelihood pose of the matched percepts (:func:`~worldgraph.pose.refine_pose`)
    with the Cramer-Rao bound of its position."""
    t0 = time.perf_counter()
    pose, info = refine_pose(ego, centers, covs, start)
    timings["position"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - t_start
    w, V = np.linalg.eigh(info)
    if w[0] <= 1e-9 * w[-1]:
        return _failed("degenerate", "; ".join(notes + [
            f"the {len(pairs)} matched landmarks do not fix a 6D pose (collinear)"]),
            hyps, timings, ambiguous)
    cov = ((V / w) @ V.T)[3:, 3:]
    position = pose[:3, 3].copy()
    if status == "ok" and not reg.contains(position, tol=1e-6):
        status = "outside_region"
        notes.append(f"the pose {position.tolist()} lies outside the valid region")
    return LocalizationResult(
        transformation=pose, position=position, covariance=cov, correspondences=pairs, hypotheses=hyps,
        ambiguous=ambiguous, status=status, message="; ".join(n for n in notes if n), timings=timings)
