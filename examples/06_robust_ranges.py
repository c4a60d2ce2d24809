"""
One grossly wrong range: the L2 projection spreads it, L1 and Huber isolate it
==============================================================================

Run it from the repository root::

    python examples/06_robust_ranges.py [--out out] [--seed 0] [--error -2.5]

Six landmarks a few metres from the robot, ranges with sigma = 2 cm noise, and one range
(--bad) wrong by --error metres, so the measured radii leave the restriction polytope.
The design card's projection (objective "l2", the Gaussian density) pulls every radius a
little to absorb the error; RadialProblem with the L1 or Huber objective moves the good
ranges hardly at all and takes the bad one back.  Prints a table (objective | largest
displacement of the good radii | displacement of the bad radius | error left on the bad
radius) and saves a bar chart of the displacements.
"""

from __future__ import annotations

import numpy as np
from _common import parse_args_with, pyplot

import radialopt as ro


def scene(rng: np.random.Generator, n: int, bad: int, error: float, sigma: float):
    centers = rng.uniform(-1.0, 1.0, size=(n, 3))
    robot = np.array([4.0, 0.5, -0.3])
    true = np.linalg.norm(centers - robot, axis=1)
    radii = true + sigma * rng.standard_normal(n)
    radii[bad] += error
    return ro.make_spheres(centers, radii, sigma), true


def main() -> None:
    args = parse_args_with(__doc__, [
        ("--error", {"type": float, "default": -2.5, "help": "error of the bad range, metres"}),
        ("--bad", {"type": int, "default": 2, "help": "index of the bad range"}),
    ])
    n, sigma = 6, 0.02  # small enough for --smoke as it is
    bad = args.bad % n
    spheres, true = scene(np.random.default_rng(args.seed), n, bad, args.error, sigma)
    measured = np.array([s.radius for s in spheres])
    P = ro.RestrictionPolytope.from_spheres(spheres)
    print(f"{n} ranges, sigma {sigma * 100:.0f} cm, range {bad} wrong by {args.error:+.2f} m; "
          f"measured radii inside the polytope: {P.contains(measured)}")
    good = np.delete(np.arange(n), bad)
    rows = []
    for objective in ("l2", "l1", "huber"):
        sol = ro.RadialProblem(n, objective=objective, huber_delta=1.0).solve(spheres)
        rows.append((objective, sol))
    print("| objective | status | max good displacement (m) | bad displacement (m) | "
          "bad radius - true (m) |")
    print("|---|---|---|---|---|")
    for objective, sol in rows:
        d = sol.displacement
        print(f"| {objective} | {sol.status} | {np.max(np.abs(d[good])):.4f} | {d[bad]:+.4f} | "
              f"{sol.radii[bad] - true[bad]:+.4f} |")
    exact = ro.project_radii(spheres)
    print(f"l2 vs project_radii (active set): {np.max(np.abs(rows[0][1].radii - exact.radii)):.1e} m")

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.4, 3.4))
    width = 0.27
    for k, (objective, sol) in enumerate(rows):
        ax.bar(np.arange(n) + (k - 1) * width, sol.displacement, width, label=objective)
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xticks(np.arange(n), [f"{i}{' (bad)' if i == bad else ''}" for i in range(n)])
    ax.set_xlabel("range")
    ax.set_ylabel("displacement r' - r (m)")
    ax.set_title(f"one range wrong by {args.error:+.1f} m")
    ax.legend(title="objective", loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
              frameon=False)
    fig.tight_layout()
    path = args.out / "06_robust_ranges.png"
    fig.savefig(path, dpi=110)
    print(f"saved {path}")


if __name__ == "__main__":
    main()
