"""Benchmark: a no-rival oracle -- which one-view trials could any localiser answer uniquely?

Trials are those of ``benchmarks/layouts.py`` (its :func:`~layouts.sample_pose`,
:func:`~layouts.simulate` and :func:`~layouts.verdict`): for every kind of
:func:`worldgraph.scenes.kitchen_layout` (``--seeds`` layouts each, structural objects removed), a
robot with its head at 1.5 m and a random yaw -- optionally tilted by ``--tilt-deg`` about a random
horizontal axis through the head -- sees ``n_true`` true percepts (sigma = rho^2 / 1000) and one
false percept of a random world type.

The oracle decides, independently of the library's association (numpy and scipy only), whether a
trial has a *rival*: a pose at least 0.3 m or 5 deg from the true pose that explains the percepts
as well as the truth does.

* Candidates: every triple of percepts (i < j < k) and every ordered triple of distinct objects
  (a, b, c) of the percepts' types whose three pairwise distances match the percepts' within
  ``4 sqrt(s_i^2 + s_j^2) + 0.01`` m (per type-pair distance tables, so only matching pairs are
  extended to triples); each gives a proper rotation and a translation by Kabsch.  Candidates are
  deduplicated on a 5 cm / 1 deg grid.
* Score of a pose: every percept placed in the world, the squared Mahalanobis distance
  ``d^2 = |R x + t - X|^2 / s^2`` to every object of its type, a one-to-one assignment
  (Hungarian, cost ``min(d^2, GATE)``, GATE = 14.16 the 3-sigma gate of chi-square with 3
  degrees of freedom; pairs at the gate count as unmatched); inliers are pairs with
  ``d^2 < GATE``.  Refit until the assignment is stable (at most 5 rounds of weighted Kabsch,
  weights 1/s^2, on the inliers when >= 3, then reassign).  Robust cost = sum over percepts of
  ``min(d^2, GATE)`` (unassigned: GATE).
* Truth: the same score, refit included, started at the TRUE pose (so the truth and the rivals
  are treated alike).
* A candidate whose nearest same-type objects (per-type k-d trees, no one-to-one constraint)
  leave fewer percepts than the truth's inliers within ``LOOSE_GATE`` (9 GATE, three times the
  gate distance) is not refit: the refits move a pose too little to gain those (a speed-up,
  ``--no-prescreen`` turns it off).
* Rival: a refit candidate at least 0.3 m or 5 deg from the true pose with at least as many
  inliers as the truth and a cost at most 2.0 above the truth's.  A *level* rival also agrees
  with gravity: its tilt, the angle between ``R u`` and world z (``u = R_true^T z`` the true up
  vector in the ego frame; for a level robot the angle between ``R z`` and ``z``), is <= 5 deg.
* Determined: even without a rival, "ok" needs a pose known to ``localize``'s default 3-sigma
  tolerances (0.25 m, 5 deg).  The Cramer-Rao bound at the TRUE pose with the truth's inliers
  (isotropic percepts) and, when gravity is known (``--gravity auto`` or ``up``), gravity's tilt
  prior (``tilt_allowance / 3`` = 1.67 deg about each horizontal axis, the library's default
  ``up_sigma``) says whether an ideal estimator could meet them, on the axes ``localize``'s "weak"
  test holds to them (with gravity: position, yaw, and the tilt only to the prior's own 3 sigma
  plus 1 deg, 6 deg); "no rival and determined" is the bound on unique-correct answers (an ideal
  estimator's covariance, before any calibration).

The library on the same trial: ``worldgraph.localize(world, percepts, gravity=...)``
with every other default, judged by ``layouts.verdict`` (unique-correct: "ok", 6D NEES <= 20.06,
rotation error <= 2 deg); ``--gravity up`` passes the true up vector in the ego frame, ``none``
passes None.  ``--active`` also runs ``worldgraph.active_localize`` (max_looks=2, the same
gravity argument, every other default) with a look that sees every landmark within 30 deg of the
gaze and 0.3-8 m, measured at the TRUE pose with the same noise.

Every trial is seeded from ``--seed``, the layout kind, n_true and the trial index alone, so the
same command gives the same trials whatever the library does (compare two versions trial by
trial with ``--save``).

``--max-height H`` keeps only the landmarks at most H m above the floor (1.0: base cabinets,
no wall cabinets or upper doors): their percepts lie near one height and leave the tilt to
gravity's prior.

``--up-sigma-deg`` sets ``localize``'s ``up_sigma`` (``inf``: the 6D fit without gravity's tilt
prior, the library before it) and ``--ambiguity-margin`` its ``tol.ambiguity_margin``, to measure
either choice against the same trials.

Run:  cd benchmarks && python oracle.py [--n-true 5 7] [--poses 40] [--seeds 3] [--seed 0]
      [--kinds ...] [--tilt-deg 0] [--gravity auto|up|none] [--active] [--max-height H] [--up-sigma-deg D]
      [--ambiguity-margin M] [--save trials.json]
Prints Markdown tables and the no-rival trials the library left on the table (progress on stderr).
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
import time
from dataclasses import dataclass, field, replace

import numpy as np
from layouts import CHI2_6_3SIGMA, landmark_world, pose_error, sample_pose, simulate, verdict
from scipy.optimize import linear_sum_assignment
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from perception import Percept
from worldgraph import ASSOCIATION_TOLERANCES, scenes
from worldgraph.localization import localize

GATE = 14.16  # chi-square, 3 dof, 3 sigma
DETERMINED_POSITION = 0.25  # m: localize's default max_position_3sigma ...
DETERMINED_ROTATION_DEG = 5.0  # ... and max_rotation_3sigma
TILT_PRIOR_SD = math.radians(5.0 / 3.0)  # the library's default up_sigma: tilt_allowance / 3
# with gravity's prior the tilt is gravity's to supply: held only to the prior's own 3 sigma plus
# the 1 deg slack of the library's gravity search (its "weak" test on the tilt)
DETERMINED_TILT_DEG = max(DETERMINED_ROTATION_DEG, 3.0 * math.degrees(TILT_PRIOR_SD) + 1.0)
REFIT_ROUNDS = 5  # weighted Kabsch refits of a candidate until its assignment is stable
LOOSE_GATE = 9.0 * GATE  # the pre-screen: three times the gate distance
DIST_SIGMAS, DIST_FLOOR = 4.0, 0.01
RIVAL_POSITION, RIVAL_ROTATION_DEG, RIVAL_COST = 0.3, 5.0, 2.0
LEVEL_DEG = 5.0
DEDUP_POSITION, DEDUP_ROTATION = 0.05, math.radians(1.0)
LOOK_HALF_ANGLE_DEG, LOOK_RANGE = 30.0, 8.0
VERDICTS = ("correct", "weak", "ambiguous", "wrong", "gross", "failed")
Z = np.array([0.0, 0.0, 1.0])


# --------------------------------------------------------------------------------------------
# The oracle


class WorldTables:
    """Per-type object indices, k-d trees and type-pair distance tables of one world."""

    def __init__(self, positions: np.ndarray, types) -> None:
        self.positions = np.asarray(positions, dtype=float)
        types = np.asarray(types).astype(str)
        self.index = {str(t): np.flatnonzero(types == t) for t in np.unique(types)}
        self.trees = {t: cKDTree(self.positions[idx]) for t, idx in self.index.items()}
        self._dist: dict[tuple[str, str], np.ndarray] = {}

    def dist(self, a: str, b: str) -> np.ndarray:
        """Distances between the objects of type a (rows) and of type b (columns)."""
        key = (a, b)
        if key not in self._dist:
            pa, pb = self.positions[self.index[a]], self.positions[self.index[b]]
            self._dist[key] = np.linalg.norm(pa[:, None, :] - pb[None, :, :], axis=2)
        return self._dist[key]


def kabsch(x: np.ndarray, y: np.ndarray, w: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Proper rotation(s) R and translation(s) t minimising sum w |R x + t - y|^2.

    ``x`` (p, 3); ``y`` (p, 3) or a batch (K, p, 3), then R (K, 3, 3) and t (K, 3).
    """
    w = np.ones(len(x)) if w is None else np.asarray(w, dtype=float)
    w = w / w.sum()
    mx = w @ x
    my = np.einsum("p,...pj->...j", w, y)
    xc = x - mx
    yc = y - my[..., None, :]
    h = np.einsum("p,pi,...pj->...ij", w, xc, yc)  # sum w x y^T
    u, _, vt = np.linalg.svd(h)
    v = np.swapaxes(vt, -1, -2)
    d = np.sign(np.linalg.det(v @ np.swapaxes(u, -1, -2)))
    d = np.where(d == 0, 1.0, d)
    v = v.copy()
    v[..., :, 2] *= d[..., None]
    r = v @ np.swapaxes(u, -1, -2)
    t = my - np.einsum("...ij,j->...i", r, mx)
    return r, t


@dataclass
class Fit:
    """A pose (world_from_ego) with its one-to-one assignment."""

    R: np.ndarray
    t: np.ndarray
    matched: np.ndarray  # object index per percept, -1 unmatched
    inliers: int
    cost: float


@dataclass
class Rival:
    fit: Fit
    position_error: float  # m, from the true pose
    rotation_error: float  # deg
    tilt: float  # deg


@dataclass
class OracleResult:
    truth: Fit
    rivals: list[Rival] = field(default_factory=list)
    candidates: int = 0  # object triples that fit a percept triple
    unique: int = 0  # after the dedup
    refit: int = 0  # after the pre-screen

    @property
    def any_rival(self) -> bool:
        return bool(self.rivals)

    @property
    def level_rival(self) -> bool:
        return any(r.tilt <= LEVEL_DEG for r in self.rivals)


class _Scorer:
    """Assignment and refit of one percept set against one world."""

    def __init__(self, tables: WorldTables, types: list[str], x: np.ndarray, s: np.ndarray) -> None:
        self.tables, self.types, self.x, self.s = tables, types, x, s
        known = [t for t in dict.fromkeys(types) if t in tables.index]
        self.cols = (np.concatenate([tables.index[t] for t in known]) if known
                     else np.zeros(0, dtype=np.intp))
        col_types = np.concatenate([[t] * len(tables.index[t]) for t in known]) if known else np.zeros(0)
        self.same = np.asarray(types)[:, None] == col_types[None, :]
        self.objects = tables.positions[self.cols]

    def assign(self, R: np.ndarray, t: np.ndarray) -> Fit:
        m = len(self.x)
        matched = np.full(m, -1)
        if not len(self.cols):
            return Fit(R, t, matched, 0, GATE * m)
        placed = self.x @ R.T + t
        d2 = np.sum((placed[:, None, :] - self.objects[None, :, :]) ** 2, axis=2) / self.s[:, None] ** 2
        cost = np.where(self.same, np.minimum(d2, GATE), GATE)
        r, c = linear_sum_assignment(cost)
        inl = cost[r, c] < GATE
        matched[r[inl]] = self.cols[c[inl]]
        total = float(cost[r, c].sum()) + GATE * (m - len(r))
        return Fit(R, t, matched, int(inl.sum()), total)

    def refine(self, R: np.ndarray, t: np.ndarray) -> Fit:
        """Assign, then weighted Kabsch on the inliers and assign again until the assignment
        is stable (at most :data:`REFIT_ROUNDS` refits): a triple's pose is only as good as its
        three percepts, and one refit can leave a rival's cost several units too high."""
        fit = self.assign(R, t)
        for _ in range(REFIT_ROUNDS):
            if fit.inliers < 3:
                break
            inl = fit.matched >= 0
            R2, t2 = kabsch(self.x[inl], self.tables.positions[fit.matched[inl]], 1.0 / self.s[inl] ** 2)
            new = self.assign(R2, t2)
            if new.cost > fit.cost - 1e-9 and np.array_equal(new.matched, fit.matched):
                fit = new if new.cost <= fit.cost else fit
                break
            if new.cost > fit.cost:
                break
            fit = new
        return fit


def candidate_poses(tables: WorldTables, types: list[str], x: np.ndarray, s: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Kabsch poses of every percept triple on every distance-consistent object triple."""
    m = len(x)
    masks: dict[tuple[int, int], np.ndarray] = {}
    for i, j in itertools.combinations(range(m), 2):
        if types[i] in tables.index and types[j] in tables.index:
            d = float(np.linalg.norm(x[i] - x[j]))
            tol = DIST_SIGMAS * math.hypot(s[i], s[j]) + DIST_FLOOR
            mask = np.abs(tables.dist(types[i], types[j]) - d) <= tol
            if types[i] == types[j]:
                np.fill_diagonal(mask, False)  # distinct objects
            masks[i, j] = mask
    rs, ts = [], []
    for i, j, k in itertools.combinations(range(m), 3):
        if (i, j) not in masks or (i, k) not in masks or (j, k) not in masks:
            continue
        a, b = np.nonzero(masks[i, j])
        if not a.size:
            continue
        p, c = np.nonzero(masks[i, k][a] & masks[j, k][b])  # same-type c == a, b are off the diagonals
        if not p.size:
            continue
        ia, ib, ic = (tables.index[types[i]][a[p]], tables.index[types[j]][b[p]], tables.index[types[k]][c])
        y = np.stack([tables.positions[ia], tables.positions[ib], tables.positions[ic]], axis=1)
        r, t = kabsch(x[[i, j, k]], y)
        rs.append(r)
        ts.append(t)
    if not rs:
        return np.zeros((0, 3, 3)), np.zeros((0, 3))
    return np.concatenate(rs), np.concatenate(ts)


def determined(x: np.ndarray, s: np.ndarray, objects: np.ndarray, true_pose: np.ndarray,
               tilt_sd: float | None) -> bool:
    """Whether the Cramer-Rao bound of the pose at the truth (percepts ``x`` matched to
    ``objects``, isotropic ``s``; ``tilt_sd`` radians of gravity's prior on roll and pitch, None:
    no prior) meets the 3-sigma tolerances :data:`DETERMINED_POSITION` (worst axis) and
    :data:`DETERMINED_ROTATION_DEG` (worst axis; with the prior: about world up, the tilt about
    the worst horizontal axis within :data:`DETERMINED_TILT_DEG`), as ``localize``'s "weak" test."""
    if len(x) < 3:
        return False
    R = true_pose[:3, :3]
    rx = x @ R.T
    J = np.zeros((6, 6))  # (rotation vector on the left, translation)
    for v, si in zip(rx, s, strict=True):
        H = np.concatenate([-np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]]),
                            np.eye(3)], axis=1)
        J += H.T @ H / si**2
    if tilt_sd is not None:
        J[0, 0] += 1.0 / tilt_sd**2  # the truth maps its up vector to z: the prior pins roll, pitch
        J[1, 1] += 1.0 / tilt_sd**2
    w = np.linalg.eigvalsh(J)
    if w[0] <= 1e-12 * w[-1]:
        return False
    C = np.linalg.inv(J)
    pos3 = 3.0 * math.sqrt(float(np.linalg.eigvalsh(C[3:, 3:])[-1]))
    if tilt_sd is None:
        rot3 = math.degrees(3.0 * math.sqrt(float(np.linalg.eigvalsh(C[:3, :3])[-1])))
        return pos3 <= DETERMINED_POSITION and rot3 <= DETERMINED_ROTATION_DEG
    yaw3 = math.degrees(3.0 * math.sqrt(float(C[2, 2])))
    tilt3 = math.degrees(3.0 * math.sqrt(float(np.linalg.eigvalsh(C[:2, :2])[-1])))
    return pos3 <= DETERMINED_POSITION and yaw3 <= DETERMINED_ROTATION_DEG and tilt3 <= DETERMINED_TILT_DEG


def _rotation_deg(r1: np.ndarray, r2: np.ndarray) -> float:
    c = (np.trace(r1 @ r2.T) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def oracle(world, percepts: list[Percept], true_pose: np.ndarray, tables: WorldTables | None = None,
           prescreen: bool = True) -> OracleResult:
    """The truth's score and every rival of ``percepts`` (ego frame) in ``world`` (``positions``,
    ``types``) against the true ``world_from_ego`` (4x4)."""
    tables = tables or WorldTables(world.positions, world.types)
    types = [str(p.type) for p in percepts]
    x = np.array([np.asarray(p.position, dtype=float) for p in percepts])
    s = np.array([float(p.sigma) for p in percepts])
    scorer = _Scorer(tables, types, x, s)
    Rt, tt = true_pose[:3, :3], true_pose[:3, 3]
    truth = scorer.refine(Rt, tt)
    out = OracleResult(truth)
    rs, ts = candidate_poses(tables, types, x, s)
    out.candidates = len(rs)
    if not len(rs):
        return out
    rotvec = Rotation.from_matrix(rs).as_rotvec()
    key = np.round(np.concatenate([ts / DEDUP_POSITION, rotvec / DEDUP_ROTATION], axis=1)).astype(np.int64)
    _, first = np.unique(key, axis=0, return_index=True)
    rs, ts = rs[np.sort(first)], ts[np.sort(first)]
    out.unique = len(rs)
    if prescreen:
        placed = np.einsum("kij,pj->kpi", rs, x) + ts[:, None, :]  # (K, m, 3)
        near = np.zeros(len(rs), dtype=int)
        for i, ty in enumerate(types):
            if ty in tables.trees:
                d, _ = tables.trees[ty].query(placed[:, i], distance_upper_bound=s[i] * math.sqrt(LOOSE_GATE))
                near += np.isfinite(d)
        keep = near >= truth.inliers
        rs, ts = rs[keep], ts[keep]
    out.refit = len(rs)
    up_ego = Rt.T @ Z
    for r, t in zip(rs, ts, strict=True):
        fit = scorer.refine(r, t)
        if fit.inliers < truth.inliers or fit.cost > truth.cost + RIVAL_COST:
            continue
        dpos = float(np.linalg.norm(fit.t - tt))
        drot = _rotation_deg(fit.R, Rt)
        if dpos >= RIVAL_POSITION or drot >= RIVAL_ROTATION_DEG:
            tilt = float(np.degrees(np.arccos(np.clip(fit.R @ up_ego @ Z, -1.0, 1.0))))
            out.rivals.append(Rival(fit, dpos, drot, tilt))
    return out


# --------------------------------------------------------------------------------------------
# Trials


def below(world, max_height: float):
    """The world's landmarks at most ``max_height`` above its floor (the room's, else the lowest
    object's): a kitchen without wall cabinets, whose percepts leave the tilt to gravity."""
    room = getattr(world, "room", None)
    floor = room.lower[2] if room is not None else world.bounds[0][2]
    return world.take(np.flatnonzero(world.positions[:, 2] - floor <= max_height))


def trial_rng(seed: int, kind: str, n_true: int, index: int, stream: int = 0) -> np.random.Generator:
    """One trial's generator: a function of the seed, the kind, n_true and the index alone."""
    kinds = list(scenes.LAYOUT_KINDS + scenes.VARIED_LAYOUT_KINDS)
    kind_code = kinds.index(kind) if kind in kinds else 99
    return np.random.default_rng([seed, kind_code, n_true, index, stream])


def draw_trial(world, rng: np.random.Generator, n_true: int, tilt_deg: float, clearance: float):
    """(world_from_ego, percepts, true object per percept): the level pose of ``sample_pose``
    tilted by ``tilt_deg`` about a random horizontal axis through the head."""
    while True:
        pose = sample_pose(world, rng, clearance)
        phi = rng.uniform(0.0, 2.0 * np.pi)
        axis = np.array([math.cos(phi), math.sin(phi), 0.0])
        pose[:3, :3] = Rotation.from_rotvec(math.radians(tilt_deg) * axis).as_matrix() @ pose[:3, :3]
        sim = simulate(world, pose, rng, n_true, 1)
        if sim is not None:
            return pose, sim[0], sim[1]


def make_look(world, pose: np.ndarray, rng: np.random.Generator):
    """A look at an ego direction: every landmark within 30 deg of it and 0.3-8 m, seen from the
    TRUE pose with sigma = rho^2 / 1000."""
    R, t = pose[:3, :3], pose[:3, 3]
    ego = (world.positions - t) @ R
    rho = np.linalg.norm(ego, axis=1)
    cos_half = math.cos(math.radians(LOOK_HALF_ANGLE_DEG))

    def look(direction: np.ndarray) -> list[Percept]:
        d = np.asarray(direction, dtype=float)
        d = d / np.linalg.norm(d)
        seen = np.flatnonzero((rho >= 0.3) & (rho <= LOOK_RANGE) & (ego @ d >= cos_half * rho))
        out = []
        for o in seen:
            s = float(rho[o] ** 2 / 1000.0)
            out.append(Percept(str(world.types[o]), ego[o] + rng.normal(0.0, s, 3), s))
        return out
    return look


def _rotation_3sigma_deg(res) -> float:
    block = np.asarray(res.pose_covariance)[3:, 3:]
    if not np.all(np.isfinite(block)):
        return math.nan
    return float(np.degrees(3.0 * math.sqrt(max(float(np.linalg.eigvalsh(block).max()), 0.0))))


def run_trial(world, tables: WorldTables, kind: str, layout_seed: int, index: int, n_true: int,
              args: argparse.Namespace) -> dict:
    rng = trial_rng(args.seed, kind, n_true, index)
    pose, percepts, truth_ids = draw_trial(world, rng, n_true, args.tilt_deg, args.clearance)
    t0 = time.perf_counter()
    orc = oracle(world, percepts, pose, tables, prescreen=args.prescreen)
    oracle_ms = 1e3 * (time.perf_counter() - t0)
    gravity = {"auto": "auto", "none": None, "up": pose[:3, :3].T @ Z}[args.gravity]
    inl = orc.truth.matched >= 0
    x = np.array([p.position for p in percepts], dtype=float)
    s = np.array([p.sigma for p in percepts], dtype=float)
    pinned = determined(x[inl], s[inl], world.positions[orc.truth.matched[inl]], pose,
                        None if args.gravity == "none" else TILT_PRIOR_SD)
    t0 = time.perf_counter()
    tol = None if args.ambiguity_margin is None else replace(ASSOCIATION_TOLERANCES,
                                                             ambiguity_margin=args.ambiguity_margin)
    up_sigma = None if args.up_sigma_deg is None else math.radians(args.up_sigma_deg)
    res = localize(world, percepts, gravity=gravity, tol=tol, up_sigma=up_sigma)
    localize_ms = 1e3 * (time.perf_counter() - t0)
    v, nees = verdict(res, pose)
    dpos = drot = math.nan
    if np.all(np.isfinite(res.transformation)):
        _, dpos, drot = pose_error(res, pose)
    rec = {
        "layout": kind, "seed": layout_seed, "index": index, "n_true": n_true,
        "rival": orc.any_rival, "level_rival": orc.level_rival, "determined": pinned,
        "n_rivals": len(orc.rivals),
        "truth_inliers": orc.truth.inliers, "truth_cost": orc.truth.cost,
        "best_rival": None, "candidates": orc.candidates, "unique": orc.unique, "refit": orc.refit,
        "status": res.status, "verdict": v, "position_error": dpos, "rotation_error": drot,
        "nees": nees, "rotation_3sigma_deg": _rotation_3sigma_deg(res), "message": str(res.message)[:160],
        "oracle_ms": oracle_ms, "localize_ms": localize_ms,
    }
    if orc.rivals:
        best = min(orc.rivals, key=lambda r: r.fit.cost)
        rec["best_rival"] = {"position_error": best.position_error, "rotation_error": best.rotation_error,
                             "tilt": best.tilt, "inliers": best.fit.inliers, "cost": best.fit.cost}
    if args.active:
        from worldgraph import active_localize

        look = make_look(world, pose, trial_rng(args.seed, kind, n_true, index, stream=1))
        t0 = time.perf_counter()
        act = active_localize(world, percepts, look, max_looks=2, gravity=gravity, up_sigma=up_sigma)
        rec["active_ms"] = 1e3 * (time.perf_counter() - t0)
        rec["active_status"] = act.result.status
        rec["active_verdict"] = verdict(act.result, pose)[0]
        rec["active_looks"] = act.looks
    return rec


# --------------------------------------------------------------------------------------------
# Report


def _pct(k: int, n: int) -> str:
    return f"{100.0 * k / n:.1f} %" if n else "-"


def _mean_nees(nees: np.ndarray) -> str:
    if not nees.size:
        return "-"
    finite = np.isfinite(nees)
    text = f"{np.mean(nees[finite]):.2f}" if finite.any() else "-"
    return text if finite.all() else f"{text} (+{int(np.sum(~finite))} not finite)"


def _column(recs: list[dict], active: bool) -> list[str]:
    n = len(recs)
    no_rival = [r for r in recs if not r["rival"]]
    rival = [r for r in recs if r["rival"]]
    ok = [r for r in recs if r["status"] == "ok"]
    nees = np.array([r["nees"] for r in ok], dtype=float)
    counts = {v: sum(r["verdict"] == v for r in no_rival) for v in VERDICTS}
    wrong_pose = sum(r["status"] == "ok" and not (r["position_error"] < RIVAL_POSITION
                                                  and r["rotation_error"] < RIVAL_ROTATION_DEG)
                     for r in rival)
    unique_wrong = sum(r["verdict"] in ("wrong", "gross") for r in rival)
    cells = [
        str(n),
        _pct(len(no_rival), n),
        _pct(sum(not r["level_rival"] for r in recs), n),
        _pct(sum(not r["rival"] and r["determined"] for r in recs), n),
        _pct(sum(r["verdict"] == "correct" for r in recs), n),
    ]
    if active:
        cells.append(_pct(sum(r["active_verdict"] == "correct" for r in recs), n))
    cells += [
        " / ".join(str(counts[v]) for v in VERDICTS),
        f"{wrong_pose} ({unique_wrong})",
        _mean_nees(nees),
        _pct(int(np.sum(~(nees <= CHI2_6_3SIGMA))), len(ok)) + f" of {len(ok)}",
        f"{np.median([r['oracle_ms'] for r in recs]):.1f}" if n else "-",
        f"{np.median([r['localize_ms'] for r in recs]):.1f}" if n else "-",
    ]
    if active:
        cells.append(f"{np.median([r['active_ms'] for r in recs]):.1f}" if n else "-")
    return cells


def report(records: list[dict], args: argparse.Namespace) -> str:
    labels = ["trials", "no rival (any 6D)", f"no rival with tilt <= {LEVEL_DEG:g} deg",
              "no rival and determined (the bound)", "library unique-correct"]
    if args.active:
        labels.append("active (2 looks) unique-correct")
    labels += ["no-rival trials: correct / weak / ambiguous / ok-but-wrong (not gross) / gross / failed",
               "rival trials: ok >= 0.3 m or 5 deg off (unique-wrong by verdict)",
               "mean 6D NEES of ok answers", "ok answers with NEES > 20.06",
               "median oracle ms", "median localize ms"]
    if args.active:
        labels.append("median active_localize ms")
    out = []
    for n_true in args.n_true:
        recs = [r for r in records if r["n_true"] == n_true]
        cols = [(k, [r for r in recs if r["layout"] == k]) for k in args.kinds] + [("**all**", recs)]
        cells = [_column(rs, args.active) for _, rs in cols]
        out.append(f"\n### {n_true} true + 1 false percept\n")
        out.append("| | " + " | ".join(k for k, _ in cols) + " |")
        out.append("|---|" + "---|" * len(cols))
        for i, label in enumerate(labels):
            out.append(f"| {label} | " + " | ".join(c[i] for c in cells) + " |")
    left = [r for r in records if not r["rival"] and r["verdict"] != "correct"]
    out.append(f"\n### Left on the table: {len(left)} no-rival trials not answered unique-correct "
               f"({sum(r['determined'] for r in left)} of them determined)\n")
    if left:
        out.append("| layout | seed | trial | n_true | determined | status | position error m "
                   "| rotation error deg | rotation 3-sigma deg | message |")
        out.append("|---|---|---|---|---|---|---|---|---|---|")
        for r in left:
            msg = r["message"].replace("|", "/").replace("\n", " ")
            out.append(f"| {r['layout']} | {r['seed']} | {r['index']} | {r['n_true']} "
                       f"| {'yes' if r['determined'] else 'no'} | {r['status']} "
                       f"({r['verdict']}) | {r['position_error']:.3f} | {r['rotation_error']:.2f} "
                       f"| {r['rotation_3sigma_deg']:.2f} | {msg} |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-true", type=int, nargs="+", default=[5, 7])
    ap.add_argument("--poses", type=int, default=40, help="trials per layout kind and n_true")
    ap.add_argument("--seeds", type=int, default=3, help="layouts per kind (seeds seed .. seed + seeds - 1)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--kinds", nargs="+", default=list(scenes.LAYOUT_KINDS))
    ap.add_argument("--tilt-deg", type=float, default=0.0)
    ap.add_argument("--gravity", choices=("auto", "up", "none"), default="auto")
    ap.add_argument("--active", action="store_true")
    ap.add_argument("--up-sigma-deg", type=float, default=None,
                    help="localize's up_sigma in degrees (inf: the 6D fit without the tilt prior; default: "
                         "the library's)")
    ap.add_argument("--ambiguity-margin", type=float, default=None,
                    help="localize's tol.ambiguity_margin (default: the library's)")
    ap.add_argument("--clearance", type=float, default=0.4)
    ap.add_argument("--max-height", type=float, default=None,
                    help="keep the landmarks at most this high above the floor (m; 1.0: no wall cabinets)")
    ap.add_argument("--no-prescreen", dest="prescreen", action="store_false")
    ap.add_argument("--save", help="write per-trial records to this JSON file")
    args = ap.parse_args(argv)
    t_start = time.perf_counter()
    records: list[dict] = []
    for kind in args.kinds:
        layouts = []
        for s in range(args.seed, args.seed + args.seeds):
            w = landmark_world(scenes.kitchen_layout(kind, seed=s))
            if args.max_height is not None:
                w = below(w, args.max_height)
            layouts.append((s, w, WorldTables(w.positions, w.types)))
        for n_true in args.n_true:
            for index in range(args.poses):
                s, w, tables = layouts[index % len(layouts)]
                records.append(run_trial(w, tables, kind, s, index, n_true, args))
            done = [r for r in records if r["layout"] == kind and r["n_true"] == n_true]
            print(f"{kind} {n_true}+1: {len(done)} trials, {sum(r['rival'] for r in done)} with a rival, "
                  f"{sum(r['verdict'] == 'correct' for r in done)} unique-correct, "
                  f"{time.perf_counter() - t_start:.0f} s", file=sys.stderr, flush=True)
    elapsed = time.perf_counter() - t_start
    print(f"seed {args.seed}, {args.poses} trials per kind and n_true, {args.seeds} layouts per kind, "
          f"tilt {args.tilt_deg:g} deg, gravity {args.gravity}, up_sigma "
          f"{'default' if args.up_sigma_deg is None else f'{args.up_sigma_deg:g} deg'}; {elapsed:.0f} s")
    print(report(records, args))
    if args.save:
        with open(args.save, "w") as f:
            json.dump(records, f, indent=1, default=float)


if __name__ == "__main__":
    main()
