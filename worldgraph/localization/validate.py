"""Steps 5-8 of :func:`~worldgraph.localize` for every method but ``"paper"``: ML fits
of the best hypotheses, the range test, the choice among the fits (the region, ambiguity, fits at
the same pose) and the pose of the method."""

from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import cast

import numpy as np
from numpy.typing import NDArray

from ..association.hypotheses import AssociationHypothesis
from ..errors import PoseError
from ..pose.certificate import solve_pose_sdp
from ..pose.frames import REFINE_MAX_ITER, ml_refine, pose_information, transformation, weighted_rotation
from ..pose.gravity import TILT_GATE, TILT_SLACK, TiltPrior, tilt_angle
from ..pose.validation import (
    CHI2_3_GATE,
    CHI2_6_GATE,
    PoseFit,
    Refinement,
    calibrated_pose_covariance,
    fit_hypothesis,
    pose_cost,
    pose_difference,
    pose_nees,
    ros_pose_covariance,
    rotation_only_covariance,
    shared_range_covariance,
    shared_view_covariance,
)
from ..tolerances import COST_ROUNDING, REFINE_TOL
from .context import _Answer, _Choice, _Context, _remap
from .finish import _finish, _in_region
from .radial import _radial, _radial_score, _range_consistent, _sphere_position
from .result import LocalizationResult, LocalizeStatus
from .settings import LocalizeSettings

#: Range-only position estimator of ``radialopt.estimate_position`` behind each method.
_SPHERE_ESTIMATOR = {"spheres": "ml", "paper": "paper", "srls": "srls", "gradient": "gradient"}
#: Validation stops after this many distinct fits (hypotheses that converge to the same inliers
#: count once) ...
MAX_VALIDATED = 8
#: ... among at most this many association hypotheses.
ASSOCIATION_CANDIDATES = 32


def _validated(ctx: _Context, hyps_local: list[AssociationHypothesis]) -> LocalizationResult:
    """Validate the best hypotheses by ML fits, rank and choose, then the pose of the method."""
    fits = _fit_step(ctx, hyps_local)
    distinct, hyps = _range_step(ctx, hyps_local, fits)
    incomplete = not hyps_local[0].complete
    if not distinct and fits:  # fits exist, but the range test rejected every one of them
        return ctx.failed("inconsistent", "every hypothesis fit was rejected by the range test: no "
                          "pose fits the matched percepts' ranges", hyps, incomplete)
    if not distinct:
        return ctx.failed("degenerate", "no hypothesis keeps 3 inliers whose pose information is "
                          "regular: the matched landmarks fix no 6D pose (collinear, or their "
                          "percepts constrain too few directions)", hyps, incomplete)
    best, choice = _choose_step(ctx, distinct, incomplete)
    if ctx.settings.method == "ml":
        return _finish(ctx, _widened(_ml_pose_step(ctx, best), choice), hyps, choice)
    answer = _range_only_pose_step(ctx, best)
    if answer.status_hint in ("degenerate", "degenerate_collinear"):  # no position, so no pose
        message = answer.est.message if answer.est is not None else ""
        return ctx.failed(cast(LocalizeStatus, answer.status_hint),
                          message or "the matched landmarks fix no position", hyps, choice.ambiguous)
    return _finish(ctx, _widened(answer, choice), hyps, choice)


def _widened(answer: _Answer, choice: _Choice) -> _Answer:
    """The answer with the spread of the fits at the same pose added to its covariance."""
    if choice.spread is None:
        return answer
    return replace(answer, cov6=answer.cov6 + choice.spread)


_Fits = dict[tuple[tuple[int, int], ...], tuple[PoseFit, int]]
"""Validated fits by their inlier pairs, each with the index of the hypothesis it came from."""


def _fit_step(ctx: _Context, hyps_local: list[AssociationHypothesis]) -> _Fits:
    """Step 5: ML fits of the best hypotheses (at most :data:`MAX_VALIDATED` distinct ones)."""
    t0 = time.perf_counter()
    fits: _Fits = {}
    memo: dict[tuple[tuple[int, int], ...], Refinement] = {}  # inlier sets refined so far
    for h_i, h in enumerate(hyps_local):
        if len(fits) >= MAX_VALIDATED:
            break
        if any(pose_nees(f.world_from_ego, f.pose_covariance, h.world_from_ego) <= CHI2_6_GATE
               for f, _ in fits.values()):
            continue  # its pose lies inside a fit's 3-sigma ellipsoid: it would converge there
        # from the clique alone, and from the clique with the association's validated matches:
        # those were taken at the clique's pose without its uncertainty, and a wrong one (an
        # object one module over, far from a compact clique) can pull the fit away for good
        starts = (h.pairs,) if h.all_pairs == h.pairs else (h.pairs, h.all_pairs)
        for start in starts:
            fit = fit_hypothesis(ctx.world, ctx.ego, ctx.covs, ctx.nearest, start, h.world_from_ego,
                                 memo=memo)
            if fit is not None and fit.pairs not in fits:  # converged to the same inliers: one answer
                fits[fit.pairs] = (fit, h_i)
    ctx.timings["validation"] = time.perf_counter() - t0
    return fits


def _range_step(ctx: _Context, hyps_local: list[AssociationHypothesis], fits: _Fits
                ) -> tuple[list[tuple[PoseFit, int]], tuple[AssociationHypothesis, ...]]:
    """Step 6: the fits whose ranges meet, best first, and every hypothesis with its radial
    solution (the ranked ones first).

    Every returned hypothesis carries the radial projection of its matches' spheres (clique and
    validated percepts, :attr:`AssociationHypothesis.all_pairs`), solved by the call's
    ``solver``; with ``check=True`` the validated ones (those behind a fit, the ones the range
    test and the ranking use) are verified against vertex enumeration, the others are solved
    unchecked (the active set's answer is a certified KKT point; enumeration on every
    hypothesis would multiply the time of ``check=True``)."""
    # the card's convex problem for every validated hypothesis: the Gaussian spheres of its
    # matches (clique and validated percepts, one per distinct centre) projected
    # onto their restriction polytope; a displacement beyond the chi-square gate means ranges
    # that cannot belong to one robot position (the paper's range-consistency test)
    t0 = time.perf_counter()
    fitted = sorted({h_i for _, h_i in fits.values()})
    of_hyp = {h_i: _radial(ctx, hyps_local[h_i].all_pairs) for h_i in fitted}
    radial = {key: of_hyp[h_i] for key, (_, h_i) in fits.items()}
    ctx.timings["radial"] = time.perf_counter() - t0
    consistent = {key: v for key, v in fits.items() if _range_consistent(radial[key])}
    if len(consistent) < len(fits):
        ctx.notes.append(f"{len(fits) - len(consistent)} hypothesis fit(s) rejected: their ranges do not "
                         "meet (radial projection beyond the chi-square gate)")
    distinct = sorted(consistent.values(), key=lambda f: (f[0].cost, _radial_score(radial[f[0].pairs]),
                                                           -f[0].inliers, f[1]))
    order = [h_i for _, h_i in distinct]
    sol_of = dict(of_hyp)
    t0 = time.perf_counter()
    by_pairs = {hyps_local[i].all_pairs: sol for i, sol in sol_of.items()}
    for i, h in enumerate(hyps_local):  # the hypotheses without a fit: solved, not verified
        if i not in sol_of:
            if h.all_pairs not in by_pairs:
                by_pairs[h.all_pairs] = _radial(ctx, h.all_pairs, check=False)
            sol_of[i] = by_pairs[h.all_pairs]
    ctx.timings["radial"] += time.perf_counter() - t0
    hyps = tuple(replace(_remap(hyps_local[i], ctx.idx), radial=sol_of[i]) for i in order) + tuple(
        replace(_remap(h, ctx.idx), radial=sol_of[i]) for i, h in enumerate(hyps_local) if i not in order)
    return distinct, hyps


def _choose_step(ctx: _Context, distinct: list[tuple[PoseFit, int]], incomplete: bool
                 ) -> tuple[PoseFit, _Choice]:
    """Step 7: the best fit (inside the region when that costs little or the region is the
    caller's), its runners-up within the ambiguity margin and its log-likelihood ratio."""
    inside = [f for f in distinct if _in_region(ctx.region, f[0].world_from_ego, f[0].pose_covariance)]
    if inside and len(inside) < len(distinct):
        worse_by = inside[0][0].cost - distinct[0][0].cost
        if ctx.explicit_region or worse_by < ctx.settings.tol.ambiguity_margin:
            if inside[0] is not distinct[0]:
                ctx.notes.append(f"{len(distinct) - len(inside)} better-fitting pose(s) outside the region "
                                 "were set aside")
            distinct = inside
        else:  # the default region chooses between comparable fits, never for a far worse one
            ctx.notes.append(f"the best fit lies outside the default region; the best pose inside it fits "
                             f"worse by a robust cost of {worse_by:.3g}, so it was not preferred")
    best = distinct[0][0]
    best_cost = _likelihood_cost(ctx, best)
    tol = ctx.settings.tol
    same: list[PoseFit] = []
    others: list[PoseFit] = []
    for f, _ in distinct[1:]:
        (same if _same_pose(best.world_from_ego, f.world_from_ego, ctx.settings) else others).append(f)
    others = _level_enough(ctx, others)
    cost_of = {id(f): _likelihood_cost(ctx, f) for f in others}
    runners = [f for f in others if cost_of[id(f)] - best_cost < tol.ambiguity_margin
               and pose_nees(best.world_from_ego, best.pose_covariance, f.world_from_ego) > CHI2_6_GATE]
    # a runner-up within the tolerances is the answer, not a rival
    close = [_within_tolerance(best.world_from_ego, f.world_from_ego, ctx.settings) for f in runners]
    near = [f for f, c in zip(runners, close, strict=True) if c]
    runners = [f for f, c in zip(runners, close, strict=True) if not c]
    spread = _same_pose_spread(best, same + near)
    if same:
        ctx.notes.append(f"{len(same)} other fit(s) at the same pose (other objects of the percepts' "
                         "types nearby) widen its covariance by their likelihood-weighted spread")
    if near:
        ctx.notes.append(f"{len(near)} runner-up fit(s) within the pose tolerances of the answer "
                         f"({ctx.settings.max_position_3sigma:g} m, "
                         f"{math.degrees(ctx.settings.max_rotation_3sigma):g} deg) widen its covariance by "
                         "their likelihood-weighted spread instead of making it ambiguous")
    ambiguous = bool(runners) or incomplete
    if incomplete:
        ctx.notes.append("clique search truncated (max_nodes/max_cliques): the world repeats itself "
                         "around these percepts, other associations may be as good")
    if runners:
        gap = float(np.linalg.norm(runners[0].world_from_ego[:3, 3] - best.world_from_ego[:3, 3]))
        ctx.notes.append(f"association ambiguous: best cost {best_cost:.3g} "
                         f"({best.inliers} inliers), next {cost_of[id(runners[0])]:.3g} "
                         f"({runners[0].inliers} inliers) at a pose {gap:.3g} m away")
    llr = 0.5 * (min(cost_of.values()) - best_cost) if others else math.inf
    alternatives = tuple(f.world_from_ego.copy() for f in runners)
    near_best_costs = (float(best_cost), *(float(cost_of[id(f)]) for f in runners))
    return best, _Choice(ambiguous, alternatives, llr, near_best_costs, spread)


def _level_enough(ctx: _Context, fits: list[PoseFit]) -> list[PoseFit]:
    """The fits a gravity-search answer can be confused with: those that tilt the up vector at most
    ``tilt_allowance`` plus :data:`~worldgraph.pose.gravity.TILT_SLACK` (the gravity search's own
    limit; a fit rotated about a row of objects may explain them as well, upside down or on its
    side, and no robot that the gravity search may answer for stands so); all of them for the
    free search."""
    up = ctx.settings.plan.up
    if up is None:
        return fits
    limit = ctx.settings.tol.tilt_allowance + TILT_SLACK
    kept = [f for f in fits if tilt_angle(f.world_from_ego, up) <= limit]
    if len(kept) < len(fits):
        ctx.notes.append(f"{len(fits) - len(kept)} other fit(s) tilted beyond the tilt allowance "
                         f"({math.degrees(limit):.0f} deg) set aside: no rival of a gravity-search answer")
    return kept


def _same_pose(a: NDArray, b: NDArray, settings: LocalizeSettings) -> bool:
    """Whether two poses are one answer, as fits are that differ only in which of two
    neighbouring objects of its type a percept matched: closer than a third of the tolerances
    (``max_position_3sigma``, ``max_rotation_3sigma``; their likelihood-weighted spread then adds
    at most ``(0.71 d)^2`` to the variance, which keeps the 3-sigma bound of a sharp fit inside
    the tolerance) and than the association's ``distinct_translation`` and ``distinct_angle``
    (so lenient tolerances never merge two places into one wide answer)."""
    e = pose_difference(a, b)
    tol = settings.tol
    return bool(np.linalg.norm(e[:3]) < min(settings.max_position_3sigma / 3.0, tol.distinct_translation)
                and np.linalg.norm(e[3:]) < min(settings.max_rotation_3sigma / 3.0, tol.distinct_angle))


def _within_tolerance(a: NDArray, b: NDArray, settings: LocalizeSettings) -> bool:
    """Whether a runner-up's pose ``b`` is the answer ``a`` at the resolution the answer is asked
    for: closer than the pose tolerances (``max_position_3sigma``, ``max_rotation_3sigma``) and
    the association's ``distinct_translation`` and ``distinct_angle``.  Such a runner-up is not a
    rival: the truth being there instead is part of the answer's error, which its spread adds to
    the covariance (and a spread too wide for the tolerances makes the answer "weak")."""
    e = pose_difference(a, b)
    tol = settings.tol
    return bool(np.linalg.norm(e[:3]) < min(settings.max_position_3sigma, tol.distinct_translation)
                and np.linalg.norm(e[3:]) < min(settings.max_rotation_3sigma, tol.distinct_angle))


def _same_pose_spread(best: PoseFit, same: list[PoseFit]) -> NDArray[np.float64] | None:
    """``sum_i w_i d_i d_i^T`` over the fits at the same pose as ``best``: ``d_i`` their pose
    minus the best's (ROS order), ``w_i`` their robust likelihood ``exp(-cost_i / 2)`` normalised
    over them and the best.  Added to the best's covariance, the sum is the mean square error of
    reporting the best pose when the truth is one of these fits (None without such fits).  The
    robust cost, not :func:`_likelihood_cost`: a fit at the same pose that leaves a sharp percept
    unexplained keeps its weight, which keeps the covariance on the safe side."""
    if not same:
        return None
    w = np.exp(-0.5 * np.array([f.cost - best.cost for f in same]))
    w = w / (1.0 + w.sum())
    d = np.array([pose_difference(best.world_from_ego, f.world_from_ego) for f in same])
    return (d * w[:, None]).T @ d


def _likelihood_cost(ctx: _Context, fit: PoseFit) -> float:
    """The fit's robust cost with each percept it leaves unexplained (outside the gate) charged
    as a false percept (:func:`~worldgraph.pose.validation.false_percept_costs`): twice the
    negative log-likelihood, up to a constant, that decides ambiguity.  A pose that explains
    fewer percepts than the answer is a rival only when its missing ones are likely enough to be
    false.  The answer itself is still the fit of least robust cost: a sharp false percept (a
    few millimetres, near the head) would otherwise make any pose that happens to explain it
    the answer; where the two costs disagree, the runner-up is a rival."""
    return float(fit.cost + ctx.false_costs[fit.mahalanobis2 > CHI2_3_GATE].sum())


def _ml_pose_step(ctx: _Context, best: PoseFit) -> _Answer:
    """Step 8 (``"ml"``): the validated 6D pose (or the rotation SDP's, when better), fitted again
    with gravity's tilt prior when the gravity search answers and the percepts agree with it
    (``_tilted``), and its calibrated covariance."""
    pairs = best.pairs
    p_i = np.array([p for p, _ in pairs])
    centers = ctx.world.positions[np.array([o for _, o in pairs])]
    t0 = time.perf_counter()
    pose, information = best.world_from_ego, best.information
    if ctx.settings.certify and len(pairs) <= 4:  # few matches: the rotation SDP is a global solver
        sdp_pose, _ = solve_pose_sdp(ctx.ego[p_i], centers, ctx.covs[p_i])
        if pose_cost(sdp_pose, ctx.ego[p_i], ctx.covs[p_i], centers) < \
                pose_cost(pose, ctx.ego[p_i], ctx.covs[p_i], centers) - COST_ROUNDING:
            pose = sdp_pose
            information = pose_information(pose, ctx.ego[p_i], ctx.covs[p_i])
            ctx.notes.append("the rotation SDP found a better pose than the local fit")
    pose, information, prior = _tilted(ctx, pose, information, p_i, centers)
    cov6 = calibrated_pose_covariance(pose, ctx.ego[p_i], ctx.covs[p_i], centers,
                                      ros_pose_covariance(information), tilt_prior=prior)
    shared = [ctx.used[i].shared for i in p_i]
    if any(shared):  # errors common to the percepts of one view (head encoders)
        cov6 = cov6 + shared_view_covariance(pose, ctx.ego[p_i], ctx.covs[p_i], shared, tilt_prior=prior)
    ctx.timings["position"] = time.perf_counter() - t0
    return _Answer(pose, cov6, pairs, self_check=False, tilt_prior=prior)


def _tilted(ctx: _Context, pose: NDArray, information: NDArray, p_i: NDArray, centers: NDArray
            ) -> tuple[NDArray, NDArray, TiltPrior | None]:
    """The ML pose of the matches and gravity's tilt prior, its information and the prior; the
    6D pose unchanged (prior None) without a prior, or when the matches' own tilt contradicts it
    (:data:`~worldgraph.pose.gravity.TILT_GATE`: the gravity checks then judge the 6D tilt)."""
    prior = ctx.settings.tilt_prior
    if prior is None:
        return pose, information, None
    # the context's arrays are checked already, and the pose is the matches' ML pose (the
    # validated fit or the SDP's): the fit itself, without refine_pose's checks and global search
    try:
        tilted, info, tilt_chi2 = ml_refine(ctx.ego[p_i], centers, ctx.covs[p_i], pose, REFINE_MAX_ITER,
                                            REFINE_TOL, prior, search=False)
    except (PoseError, np.linalg.LinAlgError):
        return pose, information, None
    if tilt_chi2 > TILT_GATE:
        tilt = math.degrees(tilt_angle(pose, prior.up))
        ctx.notes.append(f"the matched percepts tilt the up vector {tilt:.1f} deg from world up, against "
                         f"gravity's tilt prior of {math.degrees(prior.sd):.2g} deg (chi-square "
                         f"{tilt_chi2:.3g} > {TILT_GATE:.3g}, 2 dof): the 6D fit stands")
        return pose, information, None
    return tilted, info, prior


def _range_only_pose_step(ctx: _Context, best: PoseFit) -> _Answer:
    """Step 8 (range-only methods): the position of the validated matches' Gaussian spheres,
    then the weighted rotation and the two-stage covariance (no pose when the position is
    degenerate: ``status_hint`` says so)."""
    pairs = best.pairs
    estimator = _SPHERE_ESTIMATOR[ctx.settings.method]
    sph = _sphere_position(ctx, pairs, estimator, best.world_from_ego[:3, 3], ctx.rng)
    sp, s_centers, sig, est, position, status, pos_cov = sph
    if status in ("degenerate", "degenerate_collinear"):
        nan = np.full((4, 4), np.nan)
        return _Answer(nan, np.full((6, 6), np.nan), pairs, est, status_hint=status)
    t0 = time.perf_counter()
    pos_var = float(np.trace(pos_cov)) / 3.0 if np.all(np.isfinite(pos_cov)) else float(np.max(sig) ** 2)
    w = 1.0 / (sig**2 + pos_var)
    rot = weighted_rotation(ctx.ego[sp], s_centers - position, w)
    pose = transformation(rot, position)
    cov6 = rotation_only_covariance(pose, ctx.ego[sp], ctx.covs[sp], w, pos_cov)
    shared = [ctx.used[i].shared for i in sp]
    if any(shared):  # errors common to the percepts of one view (head encoders)
        cov6 = cov6 + shared_range_covariance(pose, ctx.ego[sp], ctx.covs[sp], s_centers, sig, w, shared)
    ctx.timings["orientation"] = time.perf_counter() - t0
    return _Answer(pose, cov6, pairs, est, status_hint=status)
