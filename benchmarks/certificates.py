"""Benchmark: certificates of global optimality of the range-only ML position (issue 11).

Random scenes like tests/test_certificates.py: ``n`` landmarks uniform in a 10 m room, the robot
uniform inside, ``sigma = rho^2 / depth_factor`` with ``depth_factor`` log-uniform in [100, 1000].
For every scene the position certified is the one ``estimate_position(method="ml")`` returns;
an independent brute force (batched Levenberg-Marquardt from a 6^3 grid of starts, the one of
the tests) gives the reference minimum.  A false certificate is ``certified=True`` with
``f(position) > brute-force minimum + gap tolerance`` or ``lower_bound > brute-force minimum``.
The second block offers the non-global local minima of nearly coplanar scenes (robot within
0.6 m of the landmarks' plane): every one should be refused.

Run:  python benchmarks/certificates.py [--trials 300] [--seed 0] [--minima-scenes 1000]
Prints Markdown tables.  Targets: >= 99 % certified, median <= 20 ms, zero false certificates.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))

from test_certificates import local_minima, scene_batch  # noqa: E402

import radialopt as ro  # noqa: E402

TOL_ABS, TOL_REL = 1e-6, 1e-6


def _cost(c, r, s, x):
    return float(np.sum(((np.linalg.norm(c - x, axis=1) - r) / s) ** 2))


def position_rows(trials: int, seed: int) -> list[str]:
    rows = []
    for n in (4, 6, 8):
        rng = np.random.default_rng(seed + n)
        c, r, s, _ = scene_batch(rng, trials, n)
        minima = local_minima(c, r, s)
        closed = bnb = false = 0
        times = []
        for k in range(trials):
            sp = ro.make_spheres(c[k], r[k], s[k])
            x = ro.estimate_position(sp).position
            t0 = time.perf_counter()
            ct = ro.certify_position(sp, x)
            times.append(time.perf_counter() - t0)
            best = minima[k][0]
            f = _cost(c[k], r[k], s[k], x)
            closed += ct.certified and ct.method == "closed_form"
            bnb += ct.certified and ct.method == "branch_and_bound"
            if ct.lower_bound > best * (1 + 1e-12) + 1e-12 or (
                    ct.certified and f > best + max(TOL_ABS, TOL_REL * best) + 1e-9):
                false += 1
        t = np.array(times) * 1e3
        rows.append(f"| {n} | {trials} | {100 * closed / trials:.1f} | {100 * bnb / trials:.1f} | "
                    f"{100 * (closed + bnb) / trials:.1f} | {np.median(t):.2f} | "
                    f"{np.percentile(t, 90):.2f} | {false} |")
    return rows


def minima_rows(scenes: int, seed: int) -> list[str]:
    rows = []
    for n in (4, 5):
        rng = np.random.default_rng(seed + 100 + n)
        c, r, s, x = scene_batch(rng, scenes, n, coplanar=True)
        mirror = x.copy()
        mirror[:, 2] = 2 * c[:, :, 2].mean(axis=1) - x[:, 2]
        found = local_minima(c, r, s, grid=3, extra=np.stack([x, mirror], axis=1))
        offered = refused = 0
        times = []
        for k, (_, kept) in enumerate(found):
            if not kept:
                continue
            low = min(fv for _, fv in kept)
            for p, fv in kept:
                if fv <= low + 1e-4:
                    continue
                offered += 1
                t0 = time.perf_counter()
                ct = ro.certify_position(ro.make_spheres(c[k], r[k], s[k]), p)
                times.append(time.perf_counter() - t0)
                refused += not ct.certified
        t = np.array(times) * 1e3 if times else np.zeros(1)
        rows.append(f"| {n} | {offered} | {100 * refused / max(offered, 1):.1f} | "
                    f"{np.median(t):.2f} | {np.percentile(t, 90):.2f} | {offered - refused} |")
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=300)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--minima-scenes", type=int, default=1000)
    args = ap.parse_args()
    print("### Position (range-only ML): certificates at the estimate_position(method='ml') result\n")
    print("| landmarks | trials | certified % closed form | certified % branch and bound | "
          "certified % total | median ms | p90 ms | false certificates |")
    print("|---|---|---|---|---|---|---|---|")
    for row in position_rows(args.trials, args.seed):
        print(row)
    print("\n### Non-global local minima offered (nearly coplanar landmarks, robot near their plane)\n")
    print("| landmarks | minima offered | refused % | median ms | p90 ms | false certificates |")
    print("|---|---|---|---|---|---|")
    for row in minima_rows(args.minima_scenes, args.seed):
        print(row)


if __name__ == "__main__":
    main()
