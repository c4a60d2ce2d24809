"""Benchmark: association and localisation in the kitchen (753 objects) and on a 20k-object floor.

For every (n_percepts, n_false) row, N random robot poses inside the kitchen (x, y uniform
0.5 m inside the walls, z = 1.5 m, yaw uniform, ego z up) each see ``n_percepts`` percepts:
``n_percepts - n_false`` true ones, drawn at random among the visible landmarks of the
percept types (within ``max_range`` and the horizontal field of view), with
``sigma = rho^2 / depth_factor`` (eq. 6) noise from :func:`perception.simulation.simulate.simulate_percepts`,
plus ``n_false`` false percepts placed in the visible region.  A localisation is
unique-and-correct when its status is "ok", the 6D NEES ``e^T C^-1 e <= 20.06`` (3 sigma of
chi-square with 6 degrees of freedom, ``C`` the returned ``pose_covariance``) and the rotation error
is <= 2 deg; "weak" (a unique pose with a 3-sigma bound beyond localize's tolerance) has a column.
Every method of ``--methods`` runs on the same percepts: "ml" (the 6D ML pose of the full 3D
percepts), "spheres" (range-only ML position of the Gaussian spheres), "paper" (the paper's
filters and radial projection).  The floor row runs the first method.

Run:  python benchmarks/association.py [--poses 200] [--seed 0] [--floor-poses 30]
Prints Markdown tables.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from scipy.spatial.transform import Rotation

from perception.simulation.simulate import simulate_percepts
from worldgraph import scenes
from worldgraph.association import AssociationTolerances, associate
from worldgraph.localization import localize
from worldgraph.model import WorldModel

CHI2_6_3SIGMA = 20.06
PERCEPT_TYPES = ("door", "handle", "drawer", "knob")


def _pose(rng: np.random.Generator, lo: np.ndarray, hi: np.ndarray, z: float) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * np.pi)).as_matrix()
    m[:2, 3] = rng.uniform(lo[:2] + 0.5, hi[:2] - 0.5)
    m[2, 3] = z
    return m


def _draw(world: WorldModel, mask: np.ndarray, rng: np.random.Generator, n_true: int, n_false: int,
          args: argparse.Namespace, pose_fn) -> tuple[np.ndarray, list, np.ndarray]:
    """A pose and its percepts: n_true true ones (random visible landmarks) and n_false false ones."""
    types = list(world.types[mask])
    pos = world.positions[mask]
    glob = np.flatnonzero(mask)
    for _ in range(1000):
        pose = pose_fn(rng)
        percepts, truth = simulate_percepts(types, pos, pose, rng, depth_factor=args.depth_factor,
                                            max_range=args.max_range, hfov_deg=args.hfov, n_false=n_false,
                                            false_types=sorted(set(types)))
        true_idx = np.flatnonzero(truth >= 0)
        if len(true_idx) < n_true:
            continue
        pick = np.concatenate([rng.choice(true_idx, n_true, replace=False), np.flatnonzero(truth < 0)])
        pick = rng.permutation(pick)
        t = truth[pick]
        return pose, [percepts[i] for i in pick], np.where(t >= 0, glob[np.maximum(t, 0)], -1)
    raise RuntimeError("no pose with enough visible landmarks")


def _rot_err_deg(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(Rotation.from_matrix(a[:3, :3].T @ b[:3, :3]).magnitude()))


def _judge(res, pose: np.ndarray) -> str:
    """'good' (status ok, 6D NEES e^T C^-1 e <= 20.06 with the returned pose_covariance, rotation
    <= 2 deg), 'ambiguous', 'weak', 'wrong' (status ok but the test fails) or 'failed' (no pose)."""
    if res.status in ("ambiguous", "weak"):
        return str(res.status)
    if res.status != "ok":
        return "failed"
    e = np.concatenate([pose[:3, 3] - res.position,
                        Rotation.from_matrix(pose[:3, :3] @ res.transformation[:3, :3].T).as_rotvec()])
    cov = res.pose_covariance
    if not np.all(np.isfinite(cov)):
        return "wrong"
    ok = float(e @ np.linalg.solve(cov, e)) <= CHI2_6_3SIGMA and _rot_err_deg(res.transformation, pose) <= 2.0
    return "good" if ok else "wrong"


def kitchen_rows(args: argparse.Namespace) -> list[str]:
    world = scenes.kitchen(seed=args.seed, link_margin=args.link_margin)
    mask = np.isin(world.types, PERCEPT_TYPES)
    lo, hi = world.bounds
    rng = np.random.default_rng(args.seed)
    rows = []
    for n_percepts in args.n_percepts:
        for n_false in args.n_false:
            n_true = n_percepts - n_false
            verdicts = ("good", "ambiguous", "weak", "wrong", "failed")
            counts = {m: dict.fromkeys(verdicts, 0) for m in args.methods}
            t_assoc = {m: [] for m in args.methods}
            t_total = {m: [] for m in args.methods}
            for _ in range(args.poses):
                pose, percepts, truth = _draw(world, mask, rng, n_true, n_false, args,
                                              lambda r: _pose(r, lo, hi, 1.5))
                for method in args.methods:  # every method on the same percepts
                    res = localize(world, percepts, method=method, tol=args.tolerances)
                    t_assoc[method].append(res.timings.get("association", np.nan))
                    t_total[method].append(res.timings.get("total", np.nan))
                    counts[method][_judge(res, pose)] += 1
            n = args.poses
            for method in args.methods:
                c = counts[method]
                ta, tt = np.array(t_assoc[method]) * 1e3, np.array(t_total[method]) * 1e3
                rows.append(f"| kitchen {len(world)} | {method} | {n_percepts} | {n_false} | {n} "
                            f"| {100 * c['good'] / n:.1f} % | {100 * c['ambiguous'] / n:.1f} % "
                            f"| {100 * c['weak'] / n:.1f} % "
                            f"| {100 * c['wrong'] / n:.1f} % | {100 * c['failed'] / n:.1f} % "
                            f"| {np.median(ta):.1f} | {np.percentile(ta, 95):.1f} | {np.median(tt):.1f} "
                            f"| {np.percentile(tt, 95):.1f} |")
                print(rows[-1], file=sys.stderr, flush=True)
    return rows


def floor_rows(args: argparse.Namespace) -> list[str]:
    world = scenes.floor(n_objects=20000, seed=args.seed, link_margin=args.link_margin)
    mask = np.ones(len(world), dtype=bool)
    tables = world.positions[world.types == "table"]
    rng = np.random.default_rng(args.seed + 1)

    def pose_fn(r: np.random.Generator) -> np.ndarray:
        m = np.eye(4)
        m[:3, :3] = Rotation.from_euler("z", r.uniform(0, 2 * np.pi)).as_matrix()
        m[:3, 3] = tables[r.integers(len(tables))] + [0.0, 0.0, 0.8]
        return m

    rows = []
    for n_percepts, n_false in ((8, 1),):
        t_assoc, t_total, good = [], [], 0
        for _ in range(args.floor_poses):
            pose, percepts, truth = _draw(world, mask, rng, n_percepts - n_false, n_false, args, pose_fn)
            t0 = time.perf_counter()
            hyps = associate(world, percepts, args.tolerances)
            t_assoc.append(time.perf_counter() - t0)
            res = localize(world, percepts, method=args.methods[0], tol=args.tolerances)
            t_total.append(res.timings["total"])
            if res.status == "ok" and np.linalg.norm(res.position - pose[:3, 3]) < 0.2 and hyps:
                good += _rot_err_deg(res.transformation, pose) <= 2.0
        ta, tt = np.array(t_assoc) * 1e3, np.array(t_total) * 1e3
        n = args.floor_poses
        rows.append(f"| floor {len(world)} | {args.methods[0]} | {n_percepts} | {n_false} | {n} "
                    f"| {100 * good / n:.1f} % (0.2 m) "
                    f"| - | - | - | - | {np.median(ta):.1f} | {np.percentile(ta, 95):.1f} "
                    f"| {np.median(tt):.1f} | {np.percentile(tt, 95):.1f} |")
        print(rows[-1], file=sys.stderr, flush=True)
    return rows


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--poses", type=int, default=200)
    ap.add_argument("--floor-poses", type=int, default=30)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--methods", nargs="+", default=["ml", "spheres", "paper"],
                    help="localize methods, each run on the same percepts")
    ap.add_argument("--depth-factor", type=float, default=1000.0)
    ap.add_argument("--max-range", type=float, default=8.0)
    ap.add_argument("--hfov", type=float, default=None, help="horizontal field of view, degrees")
    ap.add_argument("--link-margin", type=float, default=0.5)
    ap.add_argument("--n-percepts", type=int, nargs="+", default=[5, 7, 10])
    ap.add_argument("--n-false", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--gravity", action="store_true",
                    help="gravity-aligned invariants (the robot knows which way is up)")
    args = ap.parse_args(argv)
    args.tolerances = AssociationTolerances(gravity_aligned=args.gravity)
    header = ("| world | method | percepts | false | poses | unique-correct | ambiguous | weak "
              "| unique-wrong | failed | assoc median ms | assoc p95 ms | localize median ms "
              "| localize p95 ms |\n"
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    rows = kitchen_rows(args) + floor_rows(args)
    print(f"percept types {PERCEPT_TYPES} (kitchen), all types (floor); methods={args.methods}, "
          f"depth_factor={args.depth_factor}, max_range={args.max_range}, hfov={args.hfov}, "
          f"link_margin={args.link_margin}, gravity_aligned={args.gravity}\n")
    print(header)
    print("\n".join(rows))


if __name__ == "__main__":
    main()
