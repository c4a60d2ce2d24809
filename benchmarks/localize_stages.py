"""Benchmark: the design card's radial problem inside localize, active set against Clarabel.

``localize(world, percepts, solver=...)`` turns every returned hypothesis into the card's
convex problem (its Gaussian spheres projected onto their restriction polytope) and keeps the
solution on ``AssociationHypothesis.radial``.  For the same percepts (seeded robot poses in the
kitchen layouts and the paper's kitchen, 7 true percepts + 1 false, sigma = rho^2 / 1000) this
prints, per solver: hypothesis sets solved per call, time per set (median and p95), the radial
stage per call, the whole localize call, and the largest distance of a Clarabel answer from the
exact active-set answer on the same spheres.

Run:  python benchmarks/localize_stages.py [--poses 60] [--seed 0]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

_HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:] = [p for p in sys.path if os.path.abspath(p or ".") != _HERE]
sys.path.append(_HERE)

import numpy as np  # noqa: E402
from layouts import landmark_world, sample_pose, simulate  # noqa: E402

import radialopt as ro  # noqa: E402
from worldgraph import scenes  # noqa: E402
from worldgraph.localization import localize, match_spheres  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=60)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--n-true", type=int, default=7)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    worlds = [landmark_world(scenes.kitchen_layout(k, seed=args.seed)) for k in scenes.LAYOUT_KINDS]
    worlds.append(landmark_world(scenes.kitchen(seed=args.seed)))
    cases = []
    while len(cases) < args.poses:
        world = worlds[len(cases) % len(worlds)]
        sim = simulate(world, sample_pose(world, rng, 0.4), rng, args.n_true, 1)
        if sim is not None:
            cases.append((world, sim[0]))
    print("| solver | calls | hypothesis sets per call (median) | spheres per set (median) | ms per set "
          "(median / p95) | radial stage ms per call (median) | localize ms (median) "
          "| max distance to the active set (m) |")
    print("|---|---|---|---|---|---|---|---|")
    for solver in ("active_set", "CLARABEL"):
        per_set, stage, total, sets, sizes, worst = [], [], [], [], [], 0.0
        for world, percepts in cases:
            t0 = time.perf_counter()
            res = localize(world, percepts, solver=solver)
            total.append(time.perf_counter() - t0)
            evaluated = [h for h in res.hypotheses if h.radial is not None]
            sets.append(len(evaluated))
            stage.append(res.timings["radial"])
            for h in evaluated:
                per_set.append(h.radial.solve_time)
                sizes.append(len(h.radial.radii))
                if solver != "active_set":
                    exact = ro.project_radii(match_spheres(world, percepts, h.all_pairs)[2])
                    worst = max(worst, float(np.max(np.abs(exact.radii - h.radial.radii))))
        ms = np.array(per_set) * 1e3
        dist = "-" if solver == "active_set" else f"{worst:.1e}"
        print(f"| {solver} | {len(cases)} | {np.median(sets):.0f} | {np.median(sizes):.0f} "
              f"| {np.median(ms):.3f} / {np.percentile(ms, 95):.3f} | {1e3 * np.median(stage):.2f} "
              f"| {1e3 * np.median(total):.1f} | {dist} |")


if __name__ == "__main__":
    main()
