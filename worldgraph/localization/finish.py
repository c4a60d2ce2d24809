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
from ..pose.validation import CHI2_3_GATE, constrained_directions, self_check
from ..tolerances import MIN_INLIER_DIRECTIONS, REGION_SLACK
from .context import _Answer, _Choice, _Context
from .result import LOCALIZE_STATUSES, LocalizationResult, _worst_3sigma


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
    estimator's, ambiguity, the region, and the 3-sigma bounds against the tolerances
    (``"weak"``), first failure wins."""
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
            pos3, rot3 = _worst_3sigma(cov6[:3, :3]), _worst_3sigma(cov6[3:, 3:])
            if pos3 > ctx.settings.max_position_3sigma or rot3 > ctx.settings.max_rotation_3sigma:
                status = "weak"
                ctx.notes.append(f"weakly determined: 3-sigma bounds {pos3:.3g} m (tolerance "
                                 f"{ctx.settings.max_position_3sigma:.3g})"
                                 f" and {math.degrees(rot3):.3g} deg (tolerance "
                                 f"{math.degrees(ctx.settings.max_rotation_3sigma):.3g})")
    return status


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
