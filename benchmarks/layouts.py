"""Benchmark: can a robot trust localize's "ok"?  Kitchen layouts, false percepts, 6D NEES.

For every layout kind of :func:`worldgraph.scenes.kitchen_layout` (one-wall, galley, L, U,
island; several seeds each) and the paper-sized kitchen, random robot poses see ``n_true`` true
percepts and one false percept, simulated here independently of ``perception.simulation.simulate``:

* the robot stands on the floor, in free space (at least ``--clearance`` m sideways from every
  object), its head (the ego origin) at 1.5 m, ego z up (REP 103), random yaw;
* it sees landmarks 0.3-7 m away and within +-45 deg of straight ahead (no occlusion);
* each percept is the true ego position plus N(0, sigma^2 I), sigma = rho^2 / 1000 (eq. 6);
* the false percept is a random type of the world at a uniform random point in view.

Verdicts on ``localize(world, percepts)`` with every default:

* unique-correct: status "ok", 6D NEES ``e^T C^-1 e <= 20.06`` (3 sigma of chi-square with 6
  degrees of freedom) with the returned ``pose_covariance`` and rotation error <= 2 deg;
* ambiguous, weak: the status says so;
* unique-wrong: status "ok" but the test above fails; gross: status "ok" and > 0.5 m or > 10 deg
  off (a subset of unique-wrong);
* failed: any other status.

Run:  python benchmarks/layouts.py [--poses 100] [--seeds 3] [--seed 0]
Prints a Markdown table (and progress on stderr).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from perception import Percept
from worldgraph import scenes
from worldgraph.localization import localize
from worldgraph.model import WorldModel

CHI2_6_3SIGMA = 20.06
HEAD = 1.5
MIN_RANGE, MAX_RANGE, HALF_FOV = 0.3, 7.0, np.radians(45.0)
DEPTH_FACTOR = 1000.0
VERDICTS = ("correct", "ambiguous", "weak", "wrong", "gross", "failed")


def landmark_world(world: WorldModel) -> WorldModel:
    """The world without structural objects (walls, floor, ceiling are no landmarks)."""
    keep = [t for t in world.type_names if t not in scenes.STRUCTURAL_TYPES]
    return world.subset(keep) if len(keep) < len(world.type_names) else world


def sample_pose(world: WorldModel, rng: np.random.Generator, clearance: float) -> np.ndarray:
    """world_from_ego of a head at 1.5 m above a free floor point, random yaw."""
    room = getattr(world, "room", None)
    lo, hi = (room.lower, room.upper) if room is not None else world.bounds
    tree = cKDTree(world.positions[:, :2])
    for _ in range(10000):
        xy = rng.uniform(lo[:2] + clearance, hi[:2] - clearance)
        if tree.query(xy)[0] >= clearance:
            pose = np.eye(4)
            pose[:3, :3] = Rotation.from_euler("z", rng.uniform(0.0, 2.0 * np.pi)).as_matrix()
            pose[:3, 3] = [xy[0], xy[1], (lo[2] if room is not None else 0.0) + HEAD]
            return pose
    raise RuntimeError("no free floor point found")


def in_view(ego: np.ndarray) -> np.ndarray:
    rng_ = np.linalg.norm(ego, axis=1)
    bearing = np.abs(np.arctan2(ego[:, 1], ego[:, 0]))
    return (rng_ >= MIN_RANGE) & (rng_ <= MAX_RANGE) & (bearing <= HALF_FOV)


def simulate(world: WorldModel, pose: np.ndarray, rng: np.random.Generator, n_true: int, n_false: int
             ) -> tuple[list[Percept], np.ndarray] | None:
    """Percepts (shuffled) and the true object of each (-1 for false ones); None if too few in view."""
    R, t = pose[:3, :3], pose[:3, 3]
    ego_all = (world.positions - t) @ R
    visible = np.flatnonzero(in_view(ego_all))
    if len(visible) < n_true:
        return None
    pick = rng.choice(visible, n_true, replace=False)
    percepts, truth = [], []
    for o in pick:
        x = ego_all[o]
        s = float(np.dot(x, x)) / DEPTH_FACTOR
        percepts.append(Percept(str(world.types[o]), x + rng.normal(0.0, s, 3), s))
        truth.append(int(o))
    types = world.type_names
    for _ in range(n_false):
        while True:  # uniform in the viewing wedge, heights of the room's objects
            r = MAX_RANGE * rng.uniform(MIN_RANGE / MAX_RANGE, 1.0) ** (1.0 / 3.0)
            az = rng.uniform(-HALF_FOV, HALF_FOV)
            z = rng.uniform(world.bounds[0][2], world.bounds[1][2]) - t[2]
            x = np.array([r * np.cos(az), r * np.sin(az), z])
            if in_view(x[None])[0]:
                break
        s = float(np.dot(x, x)) / DEPTH_FACTOR
        percepts.append(Percept(str(types[rng.integers(len(types))]), x, s))
        truth.append(-1)
    order = rng.permutation(len(percepts))
    return [percepts[i] for i in order], np.array(truth)[order]


def pose_error(res, pose: np.ndarray) -> tuple[np.ndarray, float, float]:
    """ROS-order error (t_true - t_est, rotvec(R_true R_est^T)), metres and degrees."""
    e = np.concatenate([pose[:3, 3] - res.transformation[:3, 3],
                        Rotation.from_matrix(pose[:3, :3] @ res.transformation[:3, :3].T).as_rotvec()])
    return e, float(np.linalg.norm(e[:3])), float(np.degrees(np.linalg.norm(e[3:])))


def verdict(res, pose: np.ndarray) -> tuple[str, float]:
    """Verdict and NEES (NaN unless status ok)."""
    if res.status == "ambiguous":
        return "ambiguous", np.nan
    if res.status == "weak":
        return "weak", np.nan
    if res.status != "ok":
        return "failed", np.nan
    e, dpos, drot = pose_error(res, pose)
    try:
        nees = float(e @ np.linalg.solve(res.pose_covariance, e))
    except np.linalg.LinAlgError:
        nees = np.inf
    if dpos > 0.5 or drot > 10.0:
        return "gross", nees
    if nees <= CHI2_6_3SIGMA and drot <= 2.0:
        return "correct", nees
    return "wrong", nees


def worlds(args: argparse.Namespace) -> list[tuple[str, list[WorldModel]]]:
    seeds = range(args.seed, args.seed + args.seeds)
    out = [(kind, [landmark_world(scenes.kitchen_layout(kind, seed=s)) for s in seeds])
           for kind in args.kinds]
    if args.kitchen:
        out.append(("kitchen (paper)", [landmark_world(scenes.kitchen(seed=args.seed))]))
    return out


def row(name: str, label: str, counts: dict[str, int], times: list[float]) -> str:
    n = sum(counts[v] for v in VERDICTS)
    wrong = counts["wrong"] + counts["gross"]
    ms = np.array(times) * 1e3
    t = f"{np.median(ms):.1f} | {np.percentile(ms, 95):.1f}" if len(ms) else "- | -"
    pct = {v: f"{100 * counts[v] / n:.1f} %" for v in ("correct", "ambiguous", "weak", "failed")}
    return (f"| {name} | {label} | {n} | {pct['correct']} | {pct['ambiguous']} | {pct['weak']} "
            f"| {100 * wrong / n:.1f} % | {counts['gross']} | {pct['failed']} "
            f"| {counts['ok_bad_nees']} of {counts['ok']} | {t} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=100, help="poses per layout kind and percept count")
    ap.add_argument("--seeds", type=int, default=3, help="layouts per kind (seeds seed .. seed + seeds - 1)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--n-true", type=int, nargs="+", default=[5, 7, 10])
    ap.add_argument("--clearance", type=float, default=0.4)
    ap.add_argument("--method", default="ml")
    ap.add_argument("--kinds", nargs="*", default=list(scenes.LAYOUT_KINDS))
    ap.add_argument("--no-kitchen", dest="kitchen", action="store_false")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    header = ("| layout | percepts | trials | unique-correct | ambiguous | weak | unique-wrong | gross "
              "| failed | ok with NEES > 20.06 | localize median ms | p95 ms |")
    rows = [header, "|" + "---|" * (header.count("|") - 1)]
    keys = VERDICTS + ("ok", "ok_bad_nees")
    totals = {n: dict.fromkeys(keys, 0) for n in args.n_true}
    all_times: dict[int, list[float]] = {n: [] for n in args.n_true}
    for name, ws in worlds(args):
        for n_true in args.n_true:
            counts = dict.fromkeys(keys, 0)
            times: list[float] = []
            while len(times) < args.poses:
                world = ws[len(times) % len(ws)]
                pose = sample_pose(world, rng, args.clearance)
                sim = simulate(world, pose, rng, n_true, 1)
                if sim is None:
                    continue
                t0 = time.perf_counter()
                res = localize(world, sim[0], method=args.method)
                times.append(time.perf_counter() - t0)
                v, nees = verdict(res, pose)
                counts[v] += 1
                if res.status == "ok":
                    counts["ok"] += 1
                    counts["ok_bad_nees"] += int(not nees <= CHI2_6_3SIGMA)
            for k, c in counts.items():
                totals[n_true][k] += c
            all_times[n_true] += times
            rows.append(row(name, f"{n_true}+1", counts, times))
            print(rows[-1], file=sys.stderr, flush=True)
    for n_true, c in totals.items():
        rows.append(row("**all**", f"{n_true}+1", c, all_times[n_true]))
    print("\n".join(rows))


if __name__ == "__main__":
    main()
