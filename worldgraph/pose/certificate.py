"""Certificate of global optimality of the ML 6D pose: a 10x10 SDP relaxation over the rotation.

The ML pose of :func:`worldgraph.pose.refine_pose` minimises over ``(R, t) in SO(3) x R^3``::

    f(R, t) = sum_i r_i^T W_i r_i,   r_i = x_i - R^T (X_i - t),   W_i = C_i^-1,

``x_i`` the ego points, ``X_i`` the matched world points, ``R, t`` the rotation and translation
of ``world_from_ego``.  Refinement from a start finds a local minimum only; this module proves
(or fails to prove) that a given pose is a global minimiser, and gives a global solver.

Derivation
----------
*Linear residual.*  With ``M = R^T`` (a rotation iff ``R`` is) and ``u = R^T t`` (the
translation in ego axes), ``r_i = x_i - M X_i + u``.  Shifting ``X_i`` and ``x_i`` by their
means changes only ``u`` (free), so the centred points are used.  ``M X_i = A_i m`` with
``m = vec(M)`` (column-major) and ``A_i = X_i^T kron I_3``, so with ``y = [m; 1]`` (10,) and
``B_i = [-A_i, x_i]`` (3x10), ``r_i = B_i y + u``: the cost is a quadratic form in ``[m; u; 1]``.

*Translation eliminated (Schur complement).*  ``f = u^T W u + 2 u^T G y + y^T H y`` with
``W = sum W_i``, ``G = sum W_i B_i``, ``H = sum B_i^T W_i B_i``; the minimum over ``u`` is at
``u* = -W^-1 G y``, so ``min_t f(R, t) = y^T Q y`` with the 10x10 PSD matrix
``Q = H - G^T W^-1 G``.

*Relaxation.*  ``Z = y y^T`` is replaced by any PSD ``Z`` (10x10) with ``Z[9, 9] = 1`` and the
linear-in-``Z`` forms of the quadratic constraints of SO(3): ``M^T M = I`` (6), ``M M^T = I``
(6; not redundant in the relaxation) and right-handedness, every column the cross product of
the other two, ``m_a x m_b = m_c`` for ``(a, b, c)`` cyclic (9; each side quadratic = linear
with the homogenising entry: ``Z[m_c,k, 9] = Z[m_a,k+1, m_b,k+2] - Z[m_a,k+2, m_b,k+1]``).
The SDP ``min trace(Q Z)`` over that set is solved by Clarabel through cvxpy (``Q`` scaled to
unit norm, tight tolerances, one DPP-compiled problem re-used).

*A proven lower bound from any dual vector.*  Write the 22 constraints ``trace(A_j Z) = b_j``.
For ANY multipliers ``lam`` let ``S = Q - sum_j lam_j A_j``.  Every rotation's lifting
``y = [vec(M); 1]`` satisfies ``y^T A_j y = b_j`` and ``|y|^2 = 4``, so::

    min_t f(R, t) = y^T S y + b^T lam >= b^T lam + 4 min(0, lambda_min(S)),

a bound that needs neither the solver's optimality nor its feasibility: the solver only
proposes ``lam``.  Its accuracy is then improved without trusting the solver: the multipliers
are projected (least squares, nearest to the solver's) onto the affine set ``S y_hat = 0`` of
the candidate pose ``y_hat`` (complementary slackness, which exact optimal multipliers of a
tight relaxation satisfy), so ``b^T lam = f(y_hat)`` to rounding and ``lambda_min(S)`` is ``0``
to rounding when the pose is globally optimal and the relaxation tight.  The larger of the two
bounds (the solver's multipliers, the projected ones) is kept, lowered by a rounding margin
(``4e-13 (|H|_F + |G^T W^-1 G|_F + |sum lam A|_F)`` plus ``1e-14 f``).  ``certified`` when
``f(R_hat, t_hat) - lower_bound <= max(abs_gap, rel_gap f(R_hat, t_hat))``.  A pose worse than
the global minimum by more than that tolerance can therefore never be certified, whatever the
solver returns.

*Global solver.*  :func:`solve_pose_sdp` reads the rotation from the first-order moments
``Z[:9, 9]`` (exact when the SDP solution has rank one; the top eigenvalue of ``Z`` dominates),
projects it onto SO(3), takes the optimal translation for it and refines with
:func:`~worldgraph.pose.refine_pose`; it returns the pose and the proven lower bound.
"""

from __future__ import annotations

import threading
import time
import warnings

import numpy as np
from numpy.typing import ArrayLike, NDArray

from radialopt.certificates import Certificate

from .._checks import real_scalar
from .._rigid import rigid_transform
from ..errors import PoseError, TooFewPerceptsError, WorldGraphError
from ..tolerances import (
    CERTIFICATE_COST_ROUNDING,
    CERTIFICATE_GAP,
    CERTIFICATE_ROUNDING,
    HOMOGENEOUS_ZERO,
)
from ..tolerances import CLARABEL_OPTIONS as CLARABEL_OPTIONS  # re-exported
from .frames import MAX_POSE_COORDINATE, _covariances, _points, refine_pose, transformation
from .gravity import TiltPrior, _check_tilt_prior

__all__ = ["certify_pose", "pose_cost", "reduced_cost_matrix", "solve_pose_sdp"]


def _m(row: int, col: int) -> int:
    """Index of ``M[row, col]`` in ``vec(M)`` (column-major)."""
    return 3 * col + row


def _sym(p: int, q: int) -> NDArray[np.float64]:
    e = np.zeros((10, 10))
    e[p, q] += 0.5
    e[q, p] += 0.5
    return e


def _constraints() -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``A (22, 10, 10)`` symmetric and ``b (22,)``: ``trace(A_j Z) = b_j``."""
    mats, rhs = [_sym(9, 9)], [1.0]
    for a in range(3):
        for b in range(a, 3):
            mats.append(sum((_sym(_m(k, a), _m(k, b)) for k in range(3)), np.zeros((10, 10))))  # M^T M = I
            rhs.append(float(a == b))
            mats.append(sum((_sym(_m(a, k), _m(b, k)) for k in range(3)), np.zeros((10, 10))))  # M M^T = I
            rhs.append(float(a == b))
    for a, b, c in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):  # m_a x m_b = m_c
        for k in range(3):
            k1, k2 = (k + 1) % 3, (k + 2) % 3
            mats.append(_sym(_m(k, c), 9) - _sym(_m(k1, a), _m(k2, b)) + _sym(_m(k2, a), _m(k1, b)))
            rhs.append(0.0)
    return np.array(mats), np.array(rhs)


_A, _B = _constraints()
_A_FLAT = _A.reshape(len(_A), 100)

_CACHE: dict[str, tuple] = {}
_LOCK = threading.Lock()


def _problem(solver: str):
    """The DPP-compiled SDP, one per solver name."""
    import cvxpy as cp

    with _LOCK:
        if solver not in _CACHE:
            if solver not in cp.installed_solvers():
                raise PoseError(f"solver must be an installed cvxpy SDP solver, got {solver!r} "
                                f"(installed: {cp.installed_solvers()})")
            q = cp.Parameter((10, 10), symmetric=True)
            z = cp.Variable((10, 10), symmetric=True)
            eq = _A_FLAT @ cp.vec(z, order="C") == _B
            psd = z >> 0
            prob = cp.Problem(cp.Minimize(cp.trace(q @ z)), [eq, psd])
            _CACHE[solver] = (prob, q, z, eq, psd, threading.Lock())
        return _CACHE[solver]


def _check_inputs(ego_points: ArrayLike, world_points: ArrayLike, covariances: ArrayLike
                  ) -> tuple[NDArray, NDArray, NDArray]:
    x = _points("ego_points", ego_points)
    y = _points("world_points", world_points, len(x), "ego_points")
    if len(x) < 3:
        raise TooFewPerceptsError(f"ego_points must hold at least 3 matches for a pose, got {len(x)}")
    C = _covariances(covariances, len(x), like="ego_points")
    return x, y, C


def _check_pose(world_from_ego: ArrayLike) -> NDArray[np.float64]:
    return rigid_transform("world_from_ego", world_from_ego, max_translation=MAX_POSE_COORDINATE)


def _check_solver(solver: object) -> str:
    """An installed cvxpy solver name."""
    import cvxpy as cp

    if not isinstance(solver, str):
        raise WorldGraphError(f"solver must be the name of an installed cvxpy SDP solver, got {solver!r}")
    if solver.upper() not in cp.installed_solvers():
        raise PoseError(f"solver {solver!r} is not an installed cvxpy solver "
                        f"({', '.join(cp.installed_solvers())})")
    return solver.upper()


def _gap_tol(name: str, v: float) -> float:
    return real_scalar(name, v, minimum=0.0)


def pose_cost(ego_points: ArrayLike, world_points: ArrayLike, covariances: ArrayLike,
              world_from_ego: ArrayLike) -> float:
    """``sum_i r_i^T C_i^-1 r_i`` with ``r_i = x_i - R^T (X_i - t)`` (the cost of refine_pose)."""
    x, y, C = _check_inputs(ego_points, world_points, covariances)
    T = _check_pose(world_from_ego)
    return _cost(x, y, np.linalg.inv(C), T)


def _cost(x: NDArray, y: NDArray, Cinv: NDArray, T: NDArray, tilt_prior: TiltPrior | None = None) -> float:
    r = x - (y - T[:3, 3]) @ T[:3, :3]
    prior = tilt_prior.cost(T[:3, :3]) if tilt_prior is not None else 0.0
    return float(np.einsum("ka,kab,kb->", r, Cinv, r)) + prior


def _prior_matrix(tilt_prior: TiltPrior | None) -> NDArray[np.float64]:
    """The tilt prior's cost as a quadratic form in ``[vec(R^T); 1]`` (whose first two triples are
    the first two rows of ``R``): ``|(R up)_xy|^2 / sd^2``."""
    P = np.zeros((10, 10))
    if tilt_prior is not None:
        uu = np.outer(tilt_prior.up, tilt_prior.up) / tilt_prior.sd**2
        P[0:3, 0:3] = uu
        P[3:6, 3:6] = uu
    return P


def _reduced(x: NDArray, y: NDArray, Cinv: NDArray, tilt_prior: TiltPrior | None = None):
    """``Q`` (with the tilt prior's quadratic form), its scale, and the map ``y -> u*`` with the
    centring shifts."""
    cx, cy = x.mean(axis=0), y.mean(axis=0)
    xc, yc = x - cx, y - cy
    k = len(x)
    B = np.zeros((k, 3, 10))
    for j in range(3):  # A_i m = sum_j X_ij M[:, j]
        B[:, :, 3 * j:3 * j + 3] = -yc[:, j, None, None] * np.eye(3)
    B[:, :, 9] = xc
    H = np.einsum("kai,kab,kbj->ij", B, Cinv, B)
    G = np.einsum("kab,kbj->aj", Cinv, B)
    Wsum = Cinv.sum(axis=0)
    WinvG = np.linalg.solve(Wsum, G)
    P = G.T @ WinvG
    prior = _prior_matrix(tilt_prior)
    Q = H - P + prior
    Q = (Q + Q.T) / 2.0
    scale = float(np.linalg.norm(H) + np.linalg.norm(P) + np.linalg.norm(prior))
    return Q, scale, WinvG, cx, cy


def reduced_cost_matrix(ego_points: ArrayLike, world_points: ArrayLike, covariances: ArrayLike
                        ) -> NDArray[np.float64]:
    """The 10x10 PSD ``Q``: ``min_t f(R, t) = [vec(R^T); 1]^T Q [vec(R^T); 1]`` (centred points)."""
    x, y, C = _check_inputs(ego_points, world_points, covariances)
    return _reduced(x, y, np.linalg.inv(C))[0]


def _lift(R: NDArray) -> NDArray:
    return np.concatenate([R.T.reshape(-1, order="F"), [1.0]])


def _bound(Q: NDArray, lam: NDArray, scale: NDArray, f_ref: float) -> float:
    """Proven lower bound ``b^T lam + 4 min(0, lambda_min(Q - sum lam A))`` minus rounding."""
    L = np.einsum("j,jab->ab", lam, _A)
    S = Q - L
    lmin = float(np.linalg.eigvalsh((S + S.T) / 2.0)[0])
    margin = (CERTIFICATE_ROUNDING * (scale + float(np.linalg.norm(L)))
              + CERTIFICATE_COST_ROUNDING * abs(f_ref))
    return float(_B @ lam + 4.0 * min(0.0, lmin) - margin)


def _polish(Q: NDArray, lam0: NDArray, yhat: NDArray) -> NDArray:
    """Multipliers nearest ``lam0`` with ``(Q - sum lam A) yhat = 0`` (least squares)."""
    K = np.einsum("jab,b->aj", _A, yhat)  # (10, 22): sum lam A yhat = K lam
    rhs = Q @ yhat - K @ lam0
    delta, *_ = np.linalg.lstsq(K, rhs, rcond=None)
    return lam0 + delta


def _solve_sdp(Q: NDArray, solver: str) -> tuple[NDArray | None, NDArray | None, str]:
    """Solve the scaled SDP: ``(Z, lam)`` for the unscaled ``Q`` (None on failure), status."""
    import cvxpy as cp

    prob, q, z, eq, psd, lock = _problem(solver)
    norm = float(np.linalg.norm(Q, 2))
    if norm == 0.0:
        return None, np.zeros(len(_B)), "zero cost"
    opts = CLARABEL_OPTIONS if solver.upper() == "CLARABEL" else {}
    with lock:
        q.value = Q / norm
        try:
            with warnings.catch_warnings():  # "inaccurate" is fine: the bound does not trust it
                warnings.simplefilter("ignore")
                prob.solve(solver=solver, **opts)
        except cp.error.SolverError as exc:
            return None, None, f"solver error: {exc}"
        status = prob.status
        Z = None if z.value is None else np.array(z.value)
        lam = None if eq.dual_value is None else -np.asarray(eq.dual_value, dtype=np.float64) * norm
    return Z, lam, status


def _certify(x, y, C, T, solver, abs_gap, rel_gap, t0, tilt_prior=None) -> Certificate:
    Cinv = np.linalg.inv(C)
    Q, scale, _, _, _ = _reduced(x, y, Cinv, tilt_prior)
    f_hat = _cost(x, y, Cinv, T, tilt_prior)
    Z, lam, status = _solve_sdp(Q, solver)
    yhat = _lift(T[:3, :3])
    candidates = [np.zeros(len(_B))] if lam is None else [lam, _polish(Q, lam, yhat)]
    lb = max(0.0, *(_bound(Q, c, scale, f_hat) for c in candidates))
    lb = min(lb, f_hat)
    gap = f_hat - lb
    tol = max(abs_gap, rel_gap * f_hat)
    ok = gap <= tol
    msg = (f"SDP ({solver}, {status}): cost {f_hat:.12g}, proven lower bound {lb:.12g}, gap {gap:.3g} "
           + ("<=" if ok else ">") + f" tolerance {tol:.3g}")
    return Certificate(certified=bool(ok), method="sdp" if ok else "none", lower_bound=lb, gap=gap,
                       solve_time=time.perf_counter() - t0,
                       message=msg + ("" if ok else ": not certified"))


def certify_pose(ego_points: ArrayLike, world_points: ArrayLike, covariances: ArrayLike,
                 world_from_ego: ArrayLike, *, solver: str = "CLARABEL", abs_gap: float = CERTIFICATE_GAP,
                 rel_gap: float = CERTIFICATE_GAP, tilt_prior: TiltPrior | None = None) -> Certificate:
    """Prove (or fail to prove) that ``world_from_ego`` is a global minimiser of the ML pose cost
    (with ``tilt_prior``: of the cost with gravity's tilt prior, a quadratic form in the rotation's
    entries like the rest, so the same relaxation bounds it).

    Parameters
    ----------
    ego_points, world_points : (k, 3) float, k >= 3
    covariances : (k, 3, 3) float, SPD
        Covariance of each ego point.
    world_from_ego : (4, 4) float
        The pose to certify (e.g. :func:`~worldgraph.pose.refine_pose`'s).
    solver : str
        An installed cvxpy SDP solver (Clarabel by default).
    abs_gap, rel_gap : float, >= 0
        ``certified`` when ``f(pose) - lower_bound <= max(abs_gap, rel_gap f(pose))``.
    tilt_prior : TiltPrior, optional
        The prior the pose was fitted with (:func:`~worldgraph.pose.refine_pose`).

    Returns
    -------
    radialopt.Certificate
        ``method="sdp"`` when certified, ``"none"`` otherwise; ``lower_bound`` is a proven
        lower bound of the global minimum over SO(3) x R^3 (see the module docstring).

    Raises
    ------
    WorldGraphError, TooFewPerceptsError, PoseError
        Bad input, naming the argument; PoseError also for a solver that is not installed.
    """
    t0 = time.perf_counter()
    x, y, C = _check_inputs(ego_points, world_points, covariances)
    T = _check_pose(world_from_ego)
    abs_gap, rel_gap = _gap_tol("abs_gap", abs_gap), _gap_tol("rel_gap", rel_gap)
    solver = _check_solver(solver)
    tilt_prior = _check_tilt_prior(tilt_prior)
    try:
        return _certify(x, y, C, T, solver, abs_gap, rel_gap, t0, tilt_prior)
    except (np.linalg.LinAlgError, ArithmeticError, ValueError) as exc:
        if isinstance(exc, WorldGraphError):
            raise
        raise PoseError(f"certify_pose failed numerically: {type(exc).__name__}: {exc}") from exc


def solve_pose_sdp(ego_points: ArrayLike, world_points: ArrayLike, covariances: ArrayLike, *,
                   solver: str = "CLARABEL", tilt_prior: TiltPrior | None = None
                   ) -> tuple[NDArray[np.float64], float]:
    """Global ML pose by the SDP relaxation: rounding of its solution, then refine_pose (with
    ``tilt_prior``: of the cost with gravity's tilt prior).

    Returns
    -------
    world_from_ego : (4, 4) float
    lower_bound : float
        A proven lower bound of the global minimum cost; ``cost(world_from_ego) - lower_bound``
        bounds the sub-optimality (tiny when the relaxation is tight).
    """
    x, y, C = _check_inputs(ego_points, world_points, covariances)
    solver = _check_solver(solver)
    tilt_prior = _check_tilt_prior(tilt_prior)
    try:
        return _solve_global(x, y, C, solver, tilt_prior)
    except (np.linalg.LinAlgError, ArithmeticError, ValueError) as exc:
        if isinstance(exc, WorldGraphError):
            raise
        raise PoseError(f"solve_pose_sdp failed numerically: {type(exc).__name__}: {exc}") from exc


def _solve_global(x: NDArray, y: NDArray, C: NDArray, solver: str, tilt_prior: TiltPrior | None = None
                  ) -> tuple[NDArray[np.float64], float]:
    Cinv = np.linalg.inv(C)
    Q, scale, WinvG, cx, cy = _reduced(x, y, Cinv, tilt_prior)
    Z, lam, status = _solve_sdp(Q, solver)
    if Z is None:
        raise PoseError(f"the SDP relaxation failed with solver={solver!r}: {status}")
    starts = []
    _, v = np.linalg.eigh((Z + Z.T) / 2.0)
    for vec in (Z[:, 9], v[:, -1] / v[9, -1] if abs(v[9, -1]) > HOMOGENEOUS_ZERO else Z[:, 9]):
        u_, _, vt = np.linalg.svd(vec[:9].reshape(3, 3, order="F"))
        d = 1.0 if np.linalg.det(u_ @ vt) > 0 else -1.0
        starts.append(u_ @ np.diag([1.0, 1.0, d]) @ vt)  # M = R^T on SO(3)
    best: NDArray[np.float64] | None = None
    best_f = np.inf
    for M in starts:
        yv = np.concatenate([M.reshape(-1, order="F"), [1.0]])
        u = -WinvG @ yv  # the optimal centred translation term for this rotation
        T0 = transformation(M.T, _translation(M.T, u, cx, cy))
        try:
            T1, _ = refine_pose(x, y, C, T0, tilt_prior=tilt_prior)
        except PoseError:  # e.g. no convergence: the rounded SDP pose still counts
            T1 = T0
        for T in (T0, T1):
            f = _cost(x, y, Cinv, T, tilt_prior)
            if f < best_f:
                best, best_f = T, f
    if best is None:  # every candidate's cost was NaN
        raise PoseError("solve_pose_sdp: no candidate rotation has a finite cost")
    cands = [] if lam is None else [lam, _polish(Q, lam, _lift(best[:3, :3]))]
    lb = max([0.0] + [_bound(Q, c, scale, best_f) for c in cands])
    return best, float(min(lb, best_f))


def _translation(R: NDArray, u: NDArray, cx: NDArray, cy: NDArray) -> NDArray:
    """``t`` with ``x_i - R^T (X_i - t) = (x_i - cx) - R^T (X_i - cy) + u`` for all i."""
    # x - R^T X + R^T t = x - cx - R^T X + R^T cy + u  =>  R^T t = R^T cy + u - cx
    return cy + R @ (u - cx)
