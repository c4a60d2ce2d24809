"""Step 9 of :func:`~worldgraph.localize`: the answer checks itself (its matches'
chi-square, its inliers, the region, how well it is determined), is certified when asked and
becomes the :class:`~worldgraph.LocalizationResult`."""

from __future__ import annotations

import math
import time

import numpy as np
from numpy.typing import NDArray

import radialopt as ro

from ..errors import WorldGraphError
from ..pose.certificate import certify_pose
from ..pose.gravity import TILT_PRIOR_SIGMAS, TILT_SLACK, TiltPrior
from ..pose.validation import CHI2_3_GATE, constrained_directions, self_check
from ..tolerances import MIN_INLIER_DIRECTIONS, REGION_SLACK
from .context import _Answer, _Choice, _Context
from .result import LOCALIZE_STATUSES, LocalizationResult, _worst_3sigma
from .settings import LocalizeSettings


def _in_region(region: ro.Region, pose: NDArray, cov6: NDArray) -> bool:
    """Whether the pose's position lies in ``region`` up to its own 3-sigma uncertainty: a robot
    standing at the region's edge is not turned away because noise put its estimate just outside."""
    block = cov6[:3, :3]
    slack = 0.0
    if np.all(np.isfinite(block)):
        slack = _worst_3sigma(block)
    return bool(region.contains(pose[:3, 3], tol=REGION_SLACK + slack))


def _finish(ctx: _Context, answer: _Answer, hyps: tuple, choice: _Choice) -> LocalizationResult:
    """Step 9: the answer checks itself (its matches' chi-square, its inliers, the region, how
    well it is determined) and is certified when asked; the result."""
    p_i = np.array([p for p, _ in answer.pairs])
    centers = ctx.world.positions[np.array([o for _, o in answer.pairs])]
    status = _self_check_step(ctx, answer, p_i, centers)
    n_inl, n_dir, rmse, residuals = _inlier_step(ctx, answer)
    ambiguous = choice.ambiguous or answer.status_hint == "ambiguous"
    status = _status_step(ctx, answer, status, n_inl, n_dir, ambiguous)
    certificate = _certificate_step(ctx, answer, p_i, centers)
    ctx.timings["total"] = time.perf_counter() - ctx.t_start
    pose, cov6 = answer.pose, answer.cov6
    return LocalizationResult(
        transformation=pose.copy(), position=pose[:3, 3].copy(), covariance=cov6[:3, :3].copy(),
        correspondences=ctx.remap(answer.pairs), hypotheses=hyps,
        ambiguous=ambiguous or status == "ambiguous",
        status=status, message="; ".join(n for n in ctx.notes if n), timings=ctx.timings,  # type: ignore[arg-type]
        position_estimate=answer.est, pose_covariance=cov6, fitness=n_inl / max(ctx.n_all, 1),
        inlier_rmse=rmse, residuals=residuals, alternatives=choice.alternatives,
        log_likelihood_ratio=choice.llr, certificate=certificate, near_best_costs=choice.near_best_costs)


def _self_check_step(ctx: _Context, answer: _Answer, p_i: NDArray, centers: NDArray) -> str:
    """``"inconsistent"`` when the matched percepts placed by the pose fail their chi-square test
    (only when ``answer.self_check``), else ``"ok"``."""
    status = "ok"
    if answer.self_check:
        passed, _, msg = self_check(answer.pose, ctx.ego[p_i], ctx.covs[p_i], centers, answer.cov6)
        if not passed:
            status = "inconsistent"
            ctx.notes.append(msg)
    return status


def _inlier_step(ctx: _Context, answer: _Answer) -> tuple[int, int, float, NDArray[np.float64]]:
    """Every percept against its nearest same-type object under the pose: the number of inliers
    (chi-square gate, 3 dof), the directions they constrain
    (:func:`~worldgraph.pose.validation.constrained_directions`: 3 per isotropic percept, 2 per
    needle), their RMS distance (m) and every percept's Mahalanobis residual."""
    pose, cov6 = answer.pose, answer.cov6
    finite_cov = np.all(np.isfinite(cov6))
    d2, obj, _ = ctx.nearest.query(pose, ctx.ego, ctx.covs, cov6 if finite_cov else None)
    inl = d2 <= CHI2_3_GATE
    pred = ctx.ego @ pose[:3, :3].T + pose[:3, 3]
    dist = np.linalg.norm(pred[inl] - ctx.world.positions[obj[inl]], axis=1) if inl.any() else np.zeros(0)
    n_inl = int(inl.sum())
    n_dir = int(constrained_directions(ctx.covs[inl]).sum())
    residuals = np.full(ctx.n_all, np.nan)
    residuals[ctx.idx] = np.sqrt(d2)
    return n_inl, n_dir, float(np.sqrt(np.mean(dist**2))) if n_inl else math.nan, residuals


def _status_step(ctx: _Context, answer: _Answer, status: str, n_inl: int, n_dir: int, ambiguous: bool
                 ) -> str:
    """The status: the self-check's, then too few inliers (``n_inl`` percepts constraining
    ``n_dir`` directions, fewer than :data:`~worldgraph.tolerances.MIN_INLIER_DIRECTIONS`), the
    estimator's, ambiguity, the region, and the 3-sigma bounds of the axes the data must supply
    against the tolerances (``"weak"``, :func:`_weak_axes`), first failure wins."""
    pose, cov6 = answer.pose, answer.cov6
    if status == "ok" and n_dir < MIN_INLIER_DIRECTIONS:
        status = "inconsistent"
        ctx.notes.append(f"only {n_inl} percept(s) agree with the pose, constraining {n_dir} directions "
                         f"({MIN_INLIER_DIRECTIONS} needed: three isotropic percepts' worth; a needle-shaped "
                         "covariance constrains two)")
    if status == "ok" and answer.status_hint not in ("ok", "ambiguous"):
        # a radialopt status that localize does not know is no success
        status = answer.status_hint if answer.status_hint in LOCALIZE_STATUSES else "degenerate"
    if status == "ok" and ambiguous:
        status = "ambiguous"
    position = pose[:3, 3]
    in_region = _in_region(ctx.region, pose, cov6)
    if status == "ok" and ctx.explicit_region and not in_region:
        status = "outside_region"
        ctx.notes.append(f"the pose {position.tolist()} lies outside the valid region")
    elif not in_region:
        ctx.notes.append(f"the pose {position.tolist()} lies outside the default region")
    if status == "ok":
        if not np.all(np.isfinite(cov6)):
            status = "weak"
            ctx.notes.append("the matched landmarks do not determine the pose (infinite covariance)")
        else:
            weak = _weak_axes(cov6, ctx.settings, answer.tilt_prior)
            if weak:
                status = "weak"
                ctx.notes.append("weakly determined: " + "; ".join(weak))
    return status


def _weak_axes(cov6: NDArray[np.float64], settings: LocalizeSettings, prior: TiltPrior | None) -> list[str]:
    """The axes of a finite pose covariance whose 3-sigma bound exceeds its tolerance, each
    described (empty: the pose is determined well enough).

    The data must supply the position (``max_position_3sigma`` along its worst axis) and, without
    gravity's tilt prior, the rotation (``max_rotation_3sigma`` about its worst axis).  With the
    prior, roll and pitch are gravity's to supply: the rotation about world up (yaw) is held to
    ``max_rotation_3sigma``, the tilt (about the worst horizontal axis) only to what the prior
    itself allows, :data:`~worldgraph.pose.gravity.TILT_PRIOR_SIGMAS` of its standard deviation
    plus :data:`~worldgraph.pose.gravity.TILT_SLACK` (when that is above ``max_rotation_3sigma``):
    a level robot whose percepts lie near one height is not weak because they cannot add to what
    gravity says about its tilt."""
    out = []
    pos3, axis = _worst_axis(cov6[:3, :3])
    if pos3 > settings.max_position_3sigma:
        out.append(f"position 3-sigma {pos3:.3g} m along {_axis_text(axis)} (tolerance "
                   f"{settings.max_position_3sigma:.3g} m)")
    rot = cov6[3:, 3:]
    rot_tol = math.degrees(settings.max_rotation_3sigma)
    if prior is None:
        rot3, axis = _worst_axis(rot)
        if math.degrees(rot3) > rot_tol:
            out.append(f"rotation 3-sigma {math.degrees(rot3):.3g} deg about {_axis_text(axis)} (tolerance "
                       f"{rot_tol:.3g} deg)")
        return out
    yaw3 = math.degrees(3.0 * math.sqrt(max(float(rot[2, 2]), 0.0)))
    if yaw3 > rot_tol:
        out.append(f"yaw (rotation about world up) 3-sigma {yaw3:.3g} deg (tolerance {rot_tol:.3g} deg)")
    tilt3, axis = _worst_axis(rot[:2, :2])
    tilt_tol = max(rot_tol, math.degrees(TILT_PRIOR_SIGMAS * prior.sd + TILT_SLACK))
    if math.degrees(tilt3) > tilt_tol:
        out.append(f"tilt 3-sigma {math.degrees(tilt3):.3g} deg about {_axis_text(np.append(axis, 0.0))} "
                   f"(tolerance {tilt_tol:.3g} deg: gravity's tilt prior, {math.degrees(prior.sd):.3g} deg, "
                   f"{TILT_PRIOR_SIGMAS:g} times, plus {math.degrees(TILT_SLACK):g} deg)")
    return out


def _worst_axis(block: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
    """Three standard deviations along the worst axis of a finite covariance block (as
    ``_worst_3sigma``), and that axis."""
    w, v = np.linalg.eigh(block)
    return 3.0 * math.sqrt(max(float(w[-1]), 0.0)), v[:, -1]


def _axis_text(axis: NDArray[np.float64]) -> str:
    """A unit axis as world-axis text, its largest component positive: ``"(0.89, -0.44, 0.13)"``."""
    a = axis if axis[np.argmax(np.abs(axis))] >= 0 else -axis
    return "(" + ", ".join(f"{c:.2f}" for c in a) + ") in world axes"


def _certificate_step(ctx: _Context, answer: _Answer, p_i: NDArray, centers: NDArray
                      ) -> ro.Certificate | None:
    """With ``certify=True``: the rotation SDP's certificate of the pose (None, with a note, when
    the match set admits none)."""
    if not ctx.settings.certify:
        return None
    certificate = None
    t0 = time.perf_counter()
    try:
        certificate = certify_pose(ctx.ego[p_i], centers, ctx.covs[p_i], answer.pose,
                                   tilt_prior=answer.tilt_prior)
    except WorldGraphError as exc:  # e.g. a degenerate match set: no certificate, say why
        ctx.notes.append(f"no certificate: {exc}")
    ctx.timings["certificate"] = time.perf_counter() - t0
    return certificate
