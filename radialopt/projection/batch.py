"""Many instances of one sphere count at once: :func:`project_radii_batch` (the small-instance
dual active set vectorised across the instances, ``_batch_dual_active_set``; the others one by
one) and the loop of single solves it is tested against (``_project_radii_batch_reference``)."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._checks import MAX_SIGMA, MIN_SIGMA_RELATIVE, instance, real_array, sigma_range
from .._dual_active_set import SMALL_CORE_SPHERES
from ..errors import RadialArgumentError, SolverError
from ..polytope import pair_pattern
from ..spheres import TOLERANCES, Tolerances, check_distinct_centers
from ..tolerances import RANK_RTOL, ROUNDING_RTOL
from .project import project_radii_unchecked

__all__ = ["BATCH_CHUNK", "BatchSolution", "project_radii_batch"]


@dataclass(frozen=True)
class BatchSolution:
    """Result of :func:`project_radii_batch`: arrays over B instances."""

    radii: NDArray[np.float64]
    density: NDArray[np.float64]
    normalized_displacement: NDArray[np.float64]
    solve_time: float


def project_radii_batch(
    centers: ArrayLike, radii: ArrayLike, sigmas: ArrayLike, tol: Tolerances = TOLERANCES
) -> BatchSolution:
    """Exact projection of B instances at once, vectorised across the instances.

    Up to ``SMALL_CORE_SPHERES`` spheres every instance is solved by the dual active-set
    method of ``_ldp_pairs`` run on all instances together in
    numpy (``_batch_dual_active_set``: one step of every unfinished instance per pass, its
    working set held in n slots, the working rows' Gram systems solved as one stacked
    ``(B, n, n)`` solve).  An instance that does not settle there (a violated row dependent on
    its working rows, a singular working set, more steps than the budget) and every instance of
    more spheres is solved alone by the single-instance route (``project_radii(...,
    method="active_set")``), the reference the vectorised path is tested against.  Each answer
    is the unique optimum; the radii must satisfy ``A r <= b`` to ``tol.agreement`` times the
    instance's length scale, else :class:`~radialopt.errors.SolverError`.

    Parameters
    ----------
    centers : (B, n, 3) float
    radii, sigmas : (B, n) float
        Checked as by :func:`project_radii` (errors name the instance and sphere, e.g.
        ``radii[3, 1]``).

    Returns
    -------
    BatchSolution with ``radii (B, n)``, ``density (B,)``, ``normalized_displacement (B,)``.
    """
    instance("tol", tol, Tolerances)
    c = real_array("centers", centers, shape=("B", "n", 3))
    if c.shape[1] < 2:
        raise RadialArgumentError(f"centers must have shape (B, n, 3) with n >= 2, got shape {c.shape}")
    r = real_array("radii", radii, shape=c.shape[:2])
    sg = real_array("sigmas", sigmas, shape=c.shape[:2], max_abs=MAX_SIGMA)
    if np.any(sg <= 0):
        raise RadialArgumentError(f"sigmas{np.argwhere(sg <= 0)[0].tolist()} = {float(sg[sg <= 0][0])!r} "
                                  "must be > 0")
    if np.any(r < 0):
        raise RadialArgumentError(
            f"radii{np.argwhere(r < 0)[0].tolist()} = {float(r[r < 0][0])!r} must be >= 0")
    if c.shape[0]:
        scale = np.maximum(np.maximum(np.abs(c).max(axis=(1, 2)), r.max(axis=1)), 1.0)[:, None]
        bad = np.flatnonzero(np.any((sg < MIN_SIGMA_RELATIVE * scale) | (sg > scale / MIN_SIGMA_RELATIVE),
                                    axis=1))
        if bad.size:  # sigma_range names the sphere
            b0 = int(bad[0])
            sigma_range(f"sigmas[{b0}]", sg[b0], max(float(np.abs(c[b0]).max()), float(r[b0].max())))
    t0 = time.perf_counter()
    z, d, h = _batch_solve(c, r, sg, tol)
    _batch_check(z, d, h, r, sg, tol)
    zz = np.sum(z * z, axis=1)
    return BatchSolution(r + sg * z, np.exp(-0.5 * zz), np.sqrt(zz), time.perf_counter() - t0)


#: Instances per pass of ``_batch_dual_active_set`` (bounds its temporaries).
BATCH_CHUNK = 16384


def _batch_solve(
    c: NDArray[np.float64], r: NDArray[np.float64], sg: NDArray[np.float64], tol: Tolerances
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Whitened answers ``z (B, n)``, pair distances ``d (B, p)`` and ``h (B, m)`` of checked arrays."""
    n = c.shape[1]
    iu, ju, A, b_sign = pair_pattern(n)
    d = np.sqrt(np.sum((c[:, iu] - c[:, ju]) ** 2, axis=2))  # (B, p)
    if np.any(d <= tol.coincident):
        k = int(np.argwhere(d <= tol.coincident)[0, 0])
        check_distinct_centers(c[k], tol)
    # a C-contiguous A^T: numpy's matmul with the transposed view took 30x longer at (10^4, 4)
    h = b_sign * np.repeat(d, 3, axis=1) - r @ np.ascontiguousarray(A.T)  # (B, m)
    z = np.zeros_like(r)
    todo = np.flatnonzero(h.min(axis=1) < 0)  # the others: z = 0 exactly
    failed: list[NDArray[np.int64]] = []
    if n <= SMALL_CORE_SPHERES:
        for lo in range(0, len(todo), BATCH_CHUNK):
            idx = todo[lo:lo + BATCH_CHUNK]
            zk, ok = _batch_dual_active_set(A, sg[idx], h[idx])
            z[idx[ok]] = zk[ok]
            failed.append(idx[~ok])
        todo = np.concatenate(failed) if failed else todo[:0]
    for k in map(int, todo):  # the single-instance route
        z[k] = (project_radii_unchecked(c[k], r[k], sg[k], tol=tol).radii - r[k]) / sg[k]
    return z, d, h


def _batch_check(z: NDArray[np.float64], d: NDArray[np.float64], h: NDArray[np.float64],
                 r: NDArray[np.float64], sg: NDArray[np.float64], tol: Tolerances) -> None:
    """:class:`SolverError` naming the first instance whose radii violate ``A r <= b`` by more than
    ``tol.agreement`` times its length scale, or that are not finite."""
    if not z.size:
        return
    A = pair_pattern(z.shape[1])[2]
    violation = np.max((sg * z) @ np.ascontiguousarray(A.T) - h, axis=1)
    scale = np.maximum(np.maximum(d.max(axis=1), r.max(axis=1)), 1.0)
    bad = np.flatnonzero(~(violation <= tol.agreement * scale) | ~np.all(np.isfinite(z), axis=1))
    if bad.size:
        k = int(bad[0])
        raise SolverError(f"instance {k}: the radii violate A r <= b by {violation[k]:.3g} m "
                          f"(tolerance {tol.agreement * scale[k]:.3g} m; sigmas {sg[k].tolist()})")


def _batch_dual_active_set(
    A: NDArray[np.float64], sg: NDArray[np.float64], h: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """``min |z|^2 s.t. G_k z <= h_k`` with ``G_k = A diag(sg_k)`` for K instances at once.

    The dual active-set method of ``_ldp_pairs`` (Goldfarb and
    Idnani with the identity Hessian, the same steps and tolerances), vectorised: each
    instance keeps its working rows in n slots (``W (K, n, n)``, empty slots zero, their Gram
    diagonal one), and every pass makes one step of every unfinished instance -- pick the most
    violated row if none is being added, else move along its direction projected onto the
    working rows' null space, to the full step (the row joins a free slot) or the partial one
    (the working row whose multiplier reaches zero first leaves).  Finished instances leave the
    arrays.  Returns ``(z (K, n), ok (K,))``; ``ok`` is False where the loop did not certify a
    KKT point (the caller solves those alone).
    """
    K, n = sg.shape
    z_out = np.zeros((K, n))
    ok_out = np.zeros(K, dtype=bool)
    live = np.arange(K)
    tol = ROUNDING_RTOL * np.maximum(np.abs(h).max(axis=1), 1.0)
    z = np.zeros((K, n))
    W = np.zeros((K, n, n))
    act = np.zeros((K, n), dtype=bool)
    u = np.zeros((K, n))
    cur = np.full(K, -1)
    up = np.zeros(K)
    eye = np.eye(n, dtype=bool)
    AT = np.ascontiguousarray(A.T)
    # the first step in closed form: from z = 0 the most violated row joins the empty working
    # set with the full step t = -h_p / |g_p|^2 (instances with no violated row are done, z = 0)
    p0 = np.argmax(-h, axis=1)
    h0 = h[live, p0]
    gp0 = A[p0] * sg
    t0 = -h0 / np.sum(gp0 * gp0, axis=1)
    start = -h0 > tol
    z[start] = -t0[start, None] * gp0[start]
    W[start, 0] = gp0[start]
    act[start, 0] = True
    u[start, 0] = t0[start]
    for _ in range(4 * A.shape[0] + 8):
        if not len(live):
            break
        # instances between rows: done, or the most violated row starts to join
        pick = np.flatnonzero(cur < 0)
        out = np.zeros(len(live), dtype=bool)
        if len(pick):
            excess = (sg[pick] * z[pick]) @ AT - h[pick]
            p = np.argmax(excess, axis=1)
            done = excess[np.arange(len(p)), p] <= tol[pick]
            cur[pick[~done]] = p[~done]
            up[pick[~done]] = 0.0
            fin = pick[done]
            if len(fin):
                out[fin] = True
                ok_out[live[fin]] = np.all(~act[fin] | (u[fin] >= -tol[fin, None]), axis=1)
                z_out[live[fin]] = z[fin]
        if np.any(out):
            keep = ~out
            live, z, W, act, u = live[keep], z[keep], W[keep], act[keep], u[keep]
            cur, up, sg, h, tol = cur[keep], up[keep], sg[keep], h[keep], tol[keep]
            if not len(live):
                break
        # one step of every live instance along its row cur
        rows = np.arange(len(live))
        gp = A[cur] * sg
        gram = W @ W.transpose(0, 2, 1)
        gram[:, eye] += ~act
        try:
            rr = np.linalg.solve(gram, np.einsum("kij,kj->ki", W, gp)[..., None])[..., 0]
        except np.linalg.LinAlgError:
            break  # a singular working set: every live instance is left to the caller
        w = gp - np.einsum("ki,kij->kj", rr, W)
        gd = np.sum(w * w, axis=1)
        pos = act & (rr > 0.0)
        ratio = np.full(act.shape, np.inf)
        np.divide(u, rr, out=ratio, where=pos)
        kd = np.argmin(ratio, axis=1)
        t1 = ratio[rows, kd]
        dependent = gd <= RANK_RTOL * np.sum(gp * gp, axis=1)
        stuck = (dependent & ~np.isfinite(t1)) | ~np.all(np.isfinite(rr), axis=1)
        t2 = np.full(len(live), np.inf)
        np.divide(np.sum(gp * z, axis=1) - h[rows, cur], gd, out=t2, where=~dependent)
        t = np.minimum(t1, t2)
        t[stuck] = 0.0
        z -= np.where(dependent, 0.0, t)[:, None] * w
        u -= t[:, None] * np.where(act, rr, 0.0)
        up += t
        full = (t2 <= t1) & ~stuck
        slot = np.where(full, np.argmin(act, axis=1), kd)
        f, fs = rows[full], slot[full]
        act[f, fs] = True
        u[f, fs] = up[full]
        W[f, fs] = gp[full]
        drop = ~full & ~stuck
        dr, ds = rows[drop], slot[drop]
        act[dr, ds] = False
        u[dr, ds] = 0.0
        W[dr, ds] = 0.0
        cur[full] = -1
        if np.any(stuck):  # left to the caller (ok_out stays False)
            keep = ~stuck
            live, z, W, act, u = live[keep], z[keep], W[keep], act[keep], u[keep]
            cur, up, sg, h, tol = cur[keep], up[keep], sg[keep], h[keep], tol[keep]
    return z_out, ok_out


def _project_radii_batch_reference(
    c: NDArray[np.float64], r: NDArray[np.float64], sg: NDArray[np.float64], tol: Tolerances = TOLERANCES
) -> NDArray[np.float64]:
    """The slow, obvious batch: one single-instance solve per instance (checked arrays);
    the adjusted radii ``(B, n)``.  :func:`project_radii_batch` is tested against it."""
    out = np.empty_like(r)
    for k in range(len(r)):
        out[k] = project_radii_unchecked(c[k], r[k], sg[k], tol=tol).radii
    return out
