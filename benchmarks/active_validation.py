"""Benchmark: active validation in the kitchen (issue 14) -- where to look when "ambiguous".

Trials are drawn as in ``benchmarks/association.py``: a robot pose in the embedded kitchen
(753 objects; x, y uniform 0.5 m inside the walls, head at z = 1.5 m, uniform yaw, ego z up)
sees ``n_percepts`` percepts: ``n_percepts - 1`` true ones drawn at random among the visible
landmarks of the types door, handle, drawer, knob (within 8 m, all around) with eq.-6 noise
``sigma = rho^2 / 1000`` from :func:`perception.simulate.simulate_percepts`, plus one false
percept in the visible region.  ``localize`` runs with every default (``--gravity``: the
association's ``gravity_aligned`` invariants).

Then :func:`worldgraph.active_localize` looks at most twice while the status is in
``--look-on`` (default "ambiguous" and "weak", as ``active_localize``) or while an "ok" answer's
3-sigma rotation bound exceeds ``--goal-rotation-deg`` (default 2, as ``active_localize``), with
three ways of choosing the gaze:

* ``plan_view``: :func:`worldgraph.plan_view` (fov 60 deg, range 8 m, the four percept types);
* ``random``: a level direction at a uniformly random azimuth;
* ``discriminator``: towards the paper's discriminator object
  (:func:`worldgraph.association.discriminator` of the result's first two hypotheses, objects
  within 8 m of both), at its ego position under the chosen pose.

A look returns the percepts ``simulate_percepts`` gives at the TRUE pose (same noise model, the
four types, within 8 m) whose direction lies within 30 deg of the gaze; a look adds no false
percept (the one false percept of the trial stays).  New percepts that repeat an old one are
merged away (:func:`worldgraph.active.merge_percepts`).  Every strategy gets the same trial and
the same look noise stream.

Verdicts as in ``benchmarks/association.py``: unique-correct = status "ok", 6D NEES
``e^T C^-1 e <= 20.06`` with the returned ``pose_covariance`` and rotation error <= 2 deg;
unique-wrong = "ok" otherwise; ambiguous = status "ambiguous"; other = "weak" or a failure.

Run:  python benchmarks/active_validation.py [--trials 200] [--seed 0]
Prints Markdown tables (progress on stderr).
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np
from association import _judge as association_judge  # benchmarks/association.py
from scipy.spatial.transform import Rotation

from perception.simulate import simulate_percepts
from worldgraph import scenes
from worldgraph.active import GOAL_ROTATION_3SIGMA, active_localize, plan_view
from worldgraph.association import AssociationTolerances, discriminator
from worldgraph.localize import LocalizationResult

CHI2_6_3SIGMA = 20.06
PERCEPT_TYPES = ("door", "handle", "drawer", "knob")
FOV_DEG = 60.0
MAX_RANGE = 8.0
DEPTH_FACTOR = 1000.0
STRATEGIES = ("plan_view", "random", "discriminator")


def _pose(rng: np.random.Generator, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * np.pi)).as_matrix()
    m[:2, 3] = rng.uniform(lo[:2] + 0.5, hi[:2] - 0.5)
    m[2, 3] = 1.5
    return m


def _draw(types: list, pos: np.ndarray, lo: np.ndarray, hi: np.ndarray, rng: np.random.Generator,
          n_true: int) -> tuple[np.ndarray, list]:
    for _ in range(1000):
        pose = _pose(rng, lo, hi)
        percepts, truth = simulate_percepts(types, pos, pose, rng, depth_factor=DEPTH_FACTOR,
                                            max_range=MAX_RANGE, n_false=1, false_types=sorted(set(types)))
        true_idx = np.flatnonzero(truth >= 0)
        if len(true_idx) < n_true:
            continue
        pick = rng.permutation(np.concatenate([rng.choice(true_idx, n_true, replace=False),
                                               np.flatnonzero(truth < 0)]))
        return pose, [percepts[i] for i in pick]
    raise RuntimeError("no pose with enough visible landmarks")


def _judge(res: LocalizationResult, pose: np.ndarray) -> str:
    """benchmarks/association.py's verdict, with "weak" and failures together as "other"."""
    verdict = association_judge(res, pose)
    return verdict if verdict in ("good", "ambiguous", "wrong") else "other"


def _looker(types: list, pos: np.ndarray, pose: np.ndarray, rng: np.random.Generator):
    cos_half = math.cos(math.radians(FOV_DEG / 2))

    def look(d: np.ndarray) -> list:
        percepts, _ = simulate_percepts(types, pos, pose, rng, depth_factor=DEPTH_FACTOR, max_range=MAX_RANGE)
        return [p for p in percepts if float(p.position @ d) >= cos_half * float(np.linalg.norm(p.position))]
    return look


def run(args: argparse.Namespace) -> tuple[list[str], list[float]]:
    world = scenes.kitchen(seed=0)
    mask = np.isin(world.types, PERCEPT_TYPES)
    types, pos = list(world.types[mask]), world.positions[mask]
    lo, hi = world.bounds
    rows, plan_times = [], []
    for gravity in (False, True):
        tol = AssociationTolerances(gravity_aligned=gravity)
        for n_percepts in args.n_percepts:
            rng = np.random.default_rng([args.seed, n_percepts, int(gravity)])
            counts = {s: np.zeros((3, 4), dtype=int) for s in STRATEGIES}   # looks x verdict
            verdicts = ("good", "ambiguous", "wrong", "other")
            for trial in range(args.trials):
                pose, percepts = _draw(types, pos, lo, hi, rng, n_percepts - 1)
                look_seed = int(rng.integers(2**63))
                for s_i, strategy in enumerate(STRATEGIES):
                    choice_rng = np.random.default_rng([look_seed, s_i])

                    def planner(res: LocalizationResult, strategy: str = strategy,
                                choice_rng: np.random.Generator = choice_rng):
                        if strategy == "plan_view":
                            t0 = time.perf_counter()
                            plan = plan_view(world, res, fov_deg=FOV_DEG, max_range=MAX_RANGE,
                                             types=PERCEPT_TYPES)
                            plan_times.append(time.perf_counter() - t0)
                            return plan
                        if strategy == "random":
                            a = choice_rng.uniform(0, 2 * np.pi)
                            return np.array([math.cos(a), math.sin(a), 0.0])
                        if len(res.hypotheses) < 2:  # nothing to compare: look straight ahead
                            return np.array([1.0, 0.0, 0.0])
                        o = discriminator(world, res.hypotheses, max_range=MAX_RANGE)
                        T = res.transformation
                        d = T[:3, :3].T @ (world.positions[o] - T[:3, 3])
                        return d if np.linalg.norm(d) > 0 else np.array([1.0, 0.0, 0.0])

                    look = _looker(types, pos, pose, np.random.default_rng([look_seed, 99]))
                    out = _loop(world, percepts, look, planner, tol, args.look_on, args.goal)
                    for k in range(3):
                        res = out.results[min(k, len(out.results) - 1)]
                        counts[strategy][k, verdicts.index(_judge(res, pose))] += 1
                if (trial + 1) % 50 == 0:
                    print(f"gravity={gravity} {n_percepts} (1 false): {trial + 1} trials", file=sys.stderr,
                          flush=True)
            n = args.trials
            for strategy in STRATEGIES:
                c = 100.0 * counts[strategy] / n
                cells = " | ".join(f"{c[k, 0]:.1f} / {c[k, 1]:.1f} / {c[k, 2]:.1f}" for k in range(3))
                rows.append(f"| {n_percepts} (1 false) | {'yes' if gravity else 'no'} | {strategy} | {n} "
                            f"| {cells} | {c[2, 3]:.1f} |")
                print(rows[-1], file=sys.stderr, flush=True)
    return rows, plan_times


def _loop(world, percepts, look, planner, tol, look_on, goal):
    return active_localize(world, percepts, look, max_looks=2, planner=planner, tol=tol,
                           look_while=look_on, goal_rotation_3sigma=goal)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trials", type=int, default=200)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--n-percepts", type=int, nargs="+", default=[5, 7],
                    help="percepts per trial, one of them false (5 = 4 true + 1 false)")
    ap.add_argument("--look-on", nargs="+", default=["ambiguous", "weak"],
                    help="statuses that get looks (add 'weak' to look at unique but weak poses too)")
    ap.add_argument("--goal-rotation-deg", type=float, default=math.degrees(GOAL_ROTATION_3SIGMA),
                    help="also look while an 'ok' answer's 3-sigma rotation bound is wider (degrees; "
                         "0 = no such looks)")
    args = ap.parse_args(argv)
    args.look_on = tuple(args.look_on)
    args.goal = math.radians(args.goal_rotation_deg) if args.goal_rotation_deg > 0 else None
    t0 = time.perf_counter()
    rows, plan_times = run(args)
    ms = 1e3 * np.array(plan_times)
    print(f"kitchen (753 objects), percept types {PERCEPT_TYPES}, looks: fov {FOV_DEG:g} deg, range "
          f"{MAX_RANGE:g} m, at most 2, while the status is in {args.look_on} or an 'ok' answer's 3-sigma "
          f"rotation bound exceeds {args.goal_rotation_deg:g} deg; seed {args.seed}, "
          f"{args.trials} trials per row; {time.perf_counter() - t0:.0f} s\n")
    print("| percepts | gravity | gaze | trials | before any look: unique-correct / ambiguous / unique-wrong "
          "(%) | after 1 look | after 2 looks | other after 2 (weak, failed) % |")
    print("|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    if ms.size:
        print(f"\nplan_view: {ms.size} calls, median {np.median(ms):.1f} ms, "
              f"p95 {np.percentile(ms, 95):.1f} ms, max {ms.max():.1f} ms")


if __name__ == "__main__":
    main()
