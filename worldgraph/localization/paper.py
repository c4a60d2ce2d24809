"""The paper's pipeline (``method="paper"``): its association's best hypothesis, the radial
position and the eq.-5 rotation."""

from __future__ import annotations

import itertools
import time
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from ..association.hypotheses import AssociationHypothesis, is_ambiguous
from ..errors import PoseError
from ..pose.frames import percept_frame, pose_from_frames, transformation
from ..pose.validation import rotation_only_covariance
from .context import _Answer, _Choice, _Context, _remap
from .finish import _finish
from .radial import _distinct_centres, _radial, _sphere_position
from .result import LocalizationResult


def _paper(ctx: _Context, hyps_local: list[AssociationHypothesis]) -> LocalizationResult:
    """The paper's pipeline: its association's best hypothesis, radial position, eq. 5."""
    t0 = time.perf_counter()
    hyps = tuple(replace(_remap(h, ctx.idx), radial=_radial(ctx, h.pairs + h.validated)) for h in hyps_local)
    ctx.timings["radial"] = time.perf_counter() - t0
    ambiguous = is_ambiguous(hyps_local, ctx.settings.tol) or not hyps_local[0].complete
    best = hyps_local[0]
    if ambiguous and len(hyps_local) > 1:
        second = hyps_local[1]
        gap = float(np.linalg.norm(second.world_from_ego[:3, 3] - best.world_from_ego[:3, 3]))
        ctx.notes.append(f"association ambiguous: best cost {best.cost:.3g}, next {second.cost:.3g} "
                         f"at a pose {gap:.3g} m away")
    pairs = _distinct_centres(ctx.world, best.pairs + best.validated)
    pi, centers, sig, est, position, status, pos_cov = _sphere_position(
        ctx, pairs, "paper", best.world_from_ego[:3, 3], None)
    if status in ("degenerate", "degenerate_collinear"):
        return ctx.failed(status, est.message or "the matched landmarks fix no position", hyps, ambiguous)
    t0 = time.perf_counter()
    try:
        rot, triple = _eq5_rotation(ctx.ego[pi], centers, sig)
    except PoseError as exc:  # every matched triple of percepts (or of objects) is collinear
        return ctx.failed("degenerate", f"the paper's eq. 5 needs three matched percepts that span a "
                          f"plane; percepts {[int(ctx.idx[k]) for k in pi]} (of the percepts passed in) "
                          f"give none: {exc}", hyps, ambiguous)
    pose = transformation(rot, position)
    w = np.zeros(len(pi))
    w[triple] = 1.0
    cov6 = rotation_only_covariance(pose, ctx.ego[pi], ctx.covs[pi], w, pos_cov)
    ctx.timings["orientation"] = time.perf_counter() - t0
    if status == "ambiguous":
        ambiguous = True
    alternatives = tuple(h.world_from_ego.copy() for h in hyps_local[1:2]) if ambiguous else ()
    return _finish(ctx, _Answer(pose, cov6, pairs, est, status_hint=status), hyps,
                   _Choice(ambiguous, alternatives))


def _eq5_rotation(ego: NDArray, centers: NDArray, sigmas: NDArray, limit: int = 10
                  ) -> tuple[NDArray, NDArray[np.intp]]:
    """Rotation of eq. 5 from the matched triple whose model triangle has the largest area,
    among the ``limit`` most certain matches, trying the next largest while the percept triangle
    defines no frame; and that triple.  :class:`~worldgraph.errors.PoseError` when no triple of
    the pool has both."""
    pool = np.sort(np.argsort(sigmas, kind="stable")[:limit])
    triples = np.array(list(itertools.combinations(pool.tolist(), 3)))
    a, b, c = (centers[triples[:, i]] for i in range(3))
    areas = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    error: PoseError | None = None
    for k in np.argsort(-areas, kind="stable"):
        best = triples[int(k)]
        try:
            model = percept_frame(*centers[best])
            seen = percept_frame(*ego[best])
        except PoseError as exc:
            error = error or exc
            continue
        return pose_from_frames(model, seen)[:3, :3], best
    assert error is not None  # at least one triple was tried
    raise error
