"""Pose covariance when head-encoder errors dominate: shared per-view errors counted or not.

Each trial: the procedural kitchen, a robot at a random pose, a 20-view scan whose joint encoders
err by ``encoder_sigma`` (one draw per view, shared by its percepts) on top of the stereo noise,
fusion, then ``localize`` twice per method (``--methods``, default "ml" and the range-only
"spheres"): with the percepts' shared loadings
(``Percept.shared``) and with the same percepts stripped of them (independent errors). The table
gives the share of trials whose 6D pose error lies inside its 3-sigma gate (chi-square, 6 dof,
0.9973) and the mean NEES (6 when the covariance is right).

    python benchmarks/shared_views.py --trials 50 [--methods ml spheres]
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.spatial.transform import Rotation

import perception as pc
from worldgraph import scenes
from worldgraph.localization import localize
from worldgraph.pose.validation import CHI2_6_GATE


def ros_error(true: np.ndarray, est: np.ndarray) -> np.ndarray:
    rot = Rotation.from_matrix(true[:3, :3] @ est[:3, :3].T).as_rotvec()
    return np.concatenate([true[:3, 3] - est[:3, 3], rot])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trials", type=int, default=50)
    ap.add_argument("--encoder-deg", type=float, nargs="*", default=[0.05, 0.3])
    ap.add_argument("--depth-factor", type=float, default=3000.0)
    ap.add_argument("--methods", nargs="*", default=["ml", "spheres"])
    args = ap.parse_args()
    world = scenes.kitchen(seed=0)
    print("| method | encoder sigma | trials | answered | inside 3 sigma, shared counted | mean NEES | "
          "inside 3 sigma, independent | mean NEES |")
    print("|---|---|---|---|---|---|---|---|")
    for method, enc in ((m, e) for m in args.methods for e in args.encoder_deg):
        rows: list[tuple[float, float]] = []
        for seed in range(args.trials):
            rng = np.random.default_rng(1000 + seed)
            T = np.eye(4)
            T[:3, :3] = Rotation.from_euler("z", rng.uniform(-np.pi, np.pi)).as_matrix()
            T[:3, 3] = [rng.uniform(3.0, 7.0), rng.uniform(2.5, 5.5), 0.0]
            raw = pc.simulate_scan(world.types, world.positions, T, rng, encoder_sigma=np.radians(enc),
                                   false_rate=0.0, depth_factor=args.depth_factor)
            fused = pc.fuse_percepts(raw)
            plain = [pc.Percept(p.type, p.position, p.sigma, covariance=p.covariance, views=p.views)
                     for p in fused]
            res, r0 = localize(world, fused, method=method), localize(world, plain, method=method)
            if res.status not in ("ok", "weak", "ambiguous") or r0.status not in ("ok", "weak", "ambiguous"):
                continue
            e = ros_error(T, res.transformation)
            e0 = ros_error(T, r0.transformation)
            rows.append((float(e @ np.linalg.solve(res.pose_covariance, e)),
                         float(e0 @ np.linalg.solve(r0.pose_covariance, e0))))
        a = np.array(rows).reshape(-1, 2)
        cover = 100 * np.mean(a <= CHI2_6_GATE, axis=0)
        print(f"| {method} | {enc:g} deg | {args.trials} | {len(a)} | {cover[0]:.1f} % | "
              f"{a[:, 0].mean():.2f} | {cover[1]:.1f} % | {a[:, 1].mean():.1f} |", flush=True)


if __name__ == "__main__":
    main()
