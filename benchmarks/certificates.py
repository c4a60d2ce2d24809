"""Benchmark: certificates of global optimality of the range-only ML position.

Random scenes like tests/radialopt/test_certificates.py: ``n`` landmarks uniform in a 10 m room, the robot
uniform inside, ``sigma = rho^2 / depth_factor`` with ``depth_factor`` log-uniform in [100, 1000].
For every scene the position certified is the one ``estimate_position(method="ml")`` returns;
an independent brute force (batched Levenberg-Marquardt from a 6^3 grid of starts, the one of
the tests) gives the reference minimum.  A false certificate is ``certified=True`` with
``f(position) > brute-force minimum + gap tolerance`` or ``lower_bound > brute-force minimum``.
The second block offers the non-global local minima of nearly coplanar scenes (robot within
0.6 m of the landmarks' plane): every one should be refused.

Run:  python benchmarks/certificates.py [--trials 300] [--seed 0] [--minima-scenes 1000]
Prints Markdown tables.  Targets: >= 99 % certified, median <= 20 ms, zero false certificates.

``--pose [--pose-trials 200]`` adds the ML 6D pose table (worldgraph.pose.certificate, SDP over
the rotation): scenes of tests/worldgraph/test_pose_certificate.py (4-10 landmarks, anisotropic SPD
covariances, standard deviations ``noise * U(0.3, 1)``) at noise 3 cm, 10 cm, 30 cm and 1 m; the
pose certified is the best of a 50-start refine_pose brute force.  A false certificate is
``certified=True`` with a cost above the brute-force minimum plus the gap tolerance, or a
lower bound above that minimum; the pose rotated by 20 degrees (translation re-fitted) is also
offered and must be refused.  ``--pose-only`` skips the position tables.  Targets: >= 95 %
certified at <= 1 m noise, median <= 60 ms, zero false certificates.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "radialopt"))

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


def pose_rows(trials: int, seed: int) -> list[str]:
    from scipy.spatial.transform import Rotation
    from test_pose_certificate import best_translation, brute_force, scene

    from worldgraph.pose import transformation
    from worldgraph.pose.certificate import certify_pose

    rows = []
    for j, noise in enumerate((0.03, 0.1, 0.3, 1.0)):
        rng = np.random.default_rng(seed + 1000 + j)
        certified = false = refused = 0
        times = []
        for _ in range(trials):
            k = int(rng.integers(4, 11))
            ego, world, C, _ = scene(rng, k, noise)
            fmin, best = brute_force(rng, ego, world, C)[0]
            t0 = time.perf_counter()
            ct = certify_pose(ego, world, C, best, abs_gap=TOL_ABS, rel_gap=TOL_REL)
            times.append(time.perf_counter() - t0)
            certified += ct.certified
            if ct.lower_bound > fmin * (1 + 1e-9) + 1e-9:
                false += 1
            axis = rng.normal(size=3)
            turn = Rotation.from_rotvec(np.deg2rad(20.0) * axis / np.linalg.norm(axis)).as_matrix()
            R = turn @ best[:3, :3]
            cw = certify_pose(ego, world, C, transformation(R, best_translation(ego, world, C, R)))
            refused += not cw.certified
            false += cw.certified
        t = np.array(times) * 1e3
        rows.append(f"| {noise * 100:g} cm | {trials} | {100 * certified / trials:.1f} | "
                    f"{np.median(t):.2f} | {np.percentile(t, 90):.2f} | "
                    f"{100 * refused / trials:.1f} | {false} |")
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=300)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--minima-scenes", type=int, default=1000)
    ap.add_argument("--pose", action="store_true", help="add the ML 6D pose (SDP) table")
    ap.add_argument("--pose-only", action="store_true", help="only the ML 6D pose table")
    ap.add_argument("--pose-trials", type=int, default=200)
    args = ap.parse_args()
    if args.pose or args.pose_only:
        print("### Pose (ML 6D from matched 3D percepts): SDP certificates at the brute-force optimum\n")
        print("| noise level | trials | certified % | median ms | p90 ms | 20-degree poses refused % | "
              "false certificates (vs brute force) |")
        print("|---|---|---|---|---|---|---|")
        for row in pose_rows(args.pose_trials, args.seed):
            print(row)
        if args.pose_only:
            return
        print()
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
