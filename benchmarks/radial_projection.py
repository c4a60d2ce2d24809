"""Time the radial projection methods for n = 3..8 spheres, measured in one run.

    python benchmarks/radial_projection.py [--instances 30] [--repeat 5]

Prints a Markdown table: the median wall time per solve of every method, of a freshly built
cvxpy problem (compiled on each call, the naive use of cvxpy), of the bare least-distance
core of the active set (the plain-Python dual active set on the pair rows up to
``SMALL_CORE_SPHERES`` spheres, NNLS beyond), of the unchecked internal route that localize
and the estimators call (``project_radii_unchecked``, arrays in), and of vertex enumeration
alone; ratios against the fresh cvxpy problem from the same run; then the batch throughput of
the active-set path.  The paper's rule reports "over budget" when an instance needs more than
``PAPER_MAX_FLATS`` flats.
Instances are infeasible (the projection does work), seeded, shared by every method.

First, at n = 4: the public call from spheres and from arrays
(``project_radii(centers=, radii=, sigmas=)``), building the spheres, one ``GaussianSphere``,
``project_radii_batch`` per instance over ``--batch`` instances and the loop of single solves
it is tested against, each with its ratio to a fresh cvxpy + Clarabel problem of the same run.
``--issue34-only`` prints that table and the batch throughput only.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import radialopt as ro  # noqa: E402
from perception import depth_sigma  # noqa: E402
from radialopt._dual_active_set import _ldp_pairs, _pair_rows  # noqa: E402
from radialopt._projection_types import _Problem  # noqa: E402
from radialopt.polytope import pair_pattern  # noqa: E402
from radialopt.projection import (  # noqa: E402
    SMALL_CORE_SPHERES,
    fresh_cvxpy_problem,
    least_distance,
    project_radii_unchecked,
    solver_options,
)
from radialopt.projection.batch import _project_radii_batch_reference  # noqa: E402
from radialopt.vertices import enumerate_vertices  # noqa: E402


def instances(rng: np.random.Generator, n: int, count: int) -> list[list[ro.GaussianSphere]]:
    out = []
    while len(out) < count:
        centers = rng.uniform(-2, 2, size=(n, 3))
        robot = rng.uniform(-2, 2, size=3)
        rho = np.linalg.norm(centers - robot, axis=1)
        sig = depth_sigma(rho, 20.0, min_sigma=1e-3)  # eq. 6
        radii = np.abs(rho + 3 * sig * rng.standard_normal(n))
        if not ro.RestrictionPolytope.from_centers(centers).contains(radii):
            out.append(ro.make_spheres(centers, radii, sig))
    return out


def median_time(fn, items, repeat: int) -> float:
    """Median over items of the best-of-``repeat`` time of ``fn(item)`` (seconds)."""
    times = []
    for item in items:
        best = np.inf
        for _ in range(repeat):
            t0 = time.perf_counter()
            fn(item)
            best = min(best, time.perf_counter() - t0)
        times.append(best)
    return statistics.median(times)


def fresh_cvxpy(spheres):
    p = _Problem.build(spheres, ro.TOLERANCES)
    prob, z = fresh_cvxpy_problem(p.G, p.h)
    prob.solve(solver="CLARABEL", **solver_options("CLARABEL"))
    return z.value


def fmt(seconds: float) -> str:
    if seconds < 1e-5:
        return f"{seconds * 1e6:.1f} µs"
    if seconds < 1e-3:
        return f"{seconds * 1e6:.0f} µs"
    if seconds < 1:
        return f"{seconds * 1e3:.2f} ms"
    return f"{seconds:.2f} s"


def batch_instances(rng: np.random.Generator, n: int, count: int):
    """``count`` infeasible instances as arrays ``(count, n, 3)``, ``(count, n)``, ``(count, n)``,
    drawn as :func:`instances` draws them (vectorised)."""
    iu, ju, A, b_sign = pair_pattern(n)
    C, R, S = [], [], []
    while sum(len(c) for c in C) < count:
        c = rng.uniform(-2, 2, size=(count, n, 3))
        robot = rng.uniform(-2, 2, size=(count, 1, 3))
        rho = np.linalg.norm(c - robot, axis=2)
        sig = depth_sigma(rho.ravel(), 20.0, min_sigma=1e-3).reshape(rho.shape)
        r = np.abs(rho + 3 * sig * rng.standard_normal((count, n)))
        d = np.linalg.norm(c[:, iu] - c[:, ju], axis=2)
        bad = np.min(b_sign * np.repeat(d, 3, axis=1) - r @ A.T, axis=1) < 0
        C.append(c[bad])
        R.append(r[bad])
        S.append(sig[bad])
    return np.concatenate(C)[:count], np.concatenate(R)[:count], np.concatenate(S)[:count]


def issue34_table(rng: np.random.Generator, n: int, count: int, batch: int, repeat: int) -> None:
    """The rows at one n, every ratio against a fresh cvxpy problem of this run."""
    items = instances(rng, n, count)
    arrays = [(np.array([s.center for s in b]), np.array([s.radius for s in b]),
               np.array([s.sigma for s in b])) for b in items]
    t_fresh = median_time(fresh_cvxpy, items[: max(5, count // 3)], 1)
    t_spheres = median_time(lambda s: ro.project_radii(s), items, repeat)
    t_arrays = median_time(lambda a: ro.project_radii(centers=a[0], radii=a[1], sigmas=a[2]), arrays, repeat)
    t_sphere = median_time(lambda a: ro.GaussianSphere(a[0][0], a[1][0], a[2][0]), arrays, repeat)
    t_built = median_time(lambda a: ro.project_radii(
        [ro.GaussianSphere(c, r, s) for c, r, s in zip(a[0], a[1], a[2], strict=True)]), arrays, repeat)
    C, R, S = batch_instances(rng, n, batch)
    t_batch = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        out = ro.project_radii_batch(C, R, S)
        t_batch = min(t_batch, (time.perf_counter() - t0) / batch)
    few = min(batch, 2000)
    t0 = time.perf_counter()
    ref = _project_radii_batch_reference(C[:few], R[:few], S[:few])
    t_loop = (time.perf_counter() - t0) / few
    gap = float(np.max(np.abs(out.radii[:few] - ref)))

    def row(what: str, t: float) -> str:
        return f"| {what} | {fmt(t)} | {t_fresh / t:,.0f}x |"

    print(f"n = {n}: median over {count} infeasible instances (best of {repeat}); batch: {batch:,} "
          f"infeasible instances, best of 3; ratios against the fresh cvxpy problem of this run")
    print()
    print("| what | time | fresh cvxpy / this |")
    print("|---|---|---|")
    print(row("project_radii(spheres), spheres built beforehand", t_spheres))
    print(row("project_radii(centers=, radii=, sigmas=), arrays in", t_arrays))
    print(row(f"build {n} GaussianSpheres + project_radii(spheres)", t_built))
    print(row("one GaussianSphere(center, radius, sigma) (float64 inputs)", t_sphere))
    print(row(f"project_radii_batch, per instance (k = {batch:,})", t_batch))
    print(row(f"single-solve loop (the batch's reference), per instance ({few:,})", t_loop))
    print(row("fresh cvxpy + Clarabel problem", t_fresh))
    print()
    print(f"largest |batch - single-solve loop| over the first {few:,} instances: {gap:.1e} m")
    print()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--instances", type=int, default=30)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--max-n", type=int, default=8)
    ap.add_argument("--max-vertices-n", type=int, default=7,
                    help="largest n for the vertex-enumeration columns")
    ap.add_argument("--batch", type=int, default=10_000, help="instances of the batch row")
    ap.add_argument("--issue34-only", action="store_true",
                    help="print only the table at n = 4 and the batch throughput")
    args = ap.parse_args()
    rng = np.random.default_rng(2026)

    issue34_table(rng, 4, max(args.instances, 30), args.batch, args.repeat)
    if args.issue34_only:
        batch_throughput(rng)
        return

    print("| n | rows | active_set | unchecked | LDP core | cvxpy (cached) | cvxpy (fresh) | vertex enum | "
          "vertices (V-form) | paper | fresh/active | fresh/cached |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for n in range(3, args.max_n + 1):
        items = instances(rng, n, args.instances)
        probs = [_Problem.build(s, ro.TOLERANCES) for s in items]
        ro.project_radii(items[0], method="cvxpy")  # compile once per n (the cached path)
        rep = args.repeat
        t_act = median_time(lambda s: ro.project_radii(s), items, rep)
        arrays = [(p.centers, p.radii, p.sigmas) for p in probs]
        t_trusted = median_time(lambda a: project_radii_unchecked(*a), arrays, rep)
        if n <= SMALL_CORE_SPHERES:
            rows = [_pair_rows(c.tolist(), r.tolist(), s.tolist(), ro.TOLERANCES, c)[0]
                    for c, r, s in arrays]
            t_core = median_time(lambda rw, n=n: _ldp_pairs(rw, n), rows, rep)
        else:
            t_core = median_time(lambda p: least_distance(p.G, p.h), probs, rep)
        t_cvx = median_time(lambda s: ro.project_radii(s, method="cvxpy"), items, rep)
        t_fresh = median_time(fresh_cvxpy, items[: max(5, args.instances // 3)], 1)
        try:
            paper_s = fmt(median_time(lambda s: ro.project_radii(s, method="paper"), items, 1))
        except ro.RadialError:  # an instance beyond PAPER_MAX_FLATS (n = 8 here)
            paper_s = "over budget"
        if n <= args.max_vertices_n:
            few = items[: max(3, args.instances // (1 if n <= 5 else 6))]
            t_enum = median_time(
                lambda s: enumerate_vertices(ro.RestrictionPolytope.from_spheres(s)), few, 1)
            t_vert = median_time(lambda s: ro.project_radii(s, method="vertices"), few, 1)
            enum_s, vert_s = fmt(t_enum), fmt(t_vert)
        else:
            enum_s = vert_s = "-"
        print(f"| {n} | {3 * n * (n - 1) // 2} | {fmt(t_act)} | {fmt(t_trusted)} | {fmt(t_core)} | "
              f"{fmt(t_cvx)} | "
              f"{fmt(t_fresh)} | {enum_s} | {vert_s} | {paper_s} | "
              f"{t_fresh / t_act:.0f}x | {t_fresh / t_cvx:.1f}x |")

    print()
    batch_throughput(rng)


def batch_throughput(rng: np.random.Generator) -> None:
    """project_radii_batch against the loop of single solves, per instance, n = 4, 6, 8."""
    print("Batch throughput (one process, infeasible instances):")
    print("| n | instances | project_radii_batch per instance | single-solve loop per instance | "
          "batch solves/s |")
    print("|---|---|---|---|---|")
    for n in (4, 6, 8):
        C, R, S = batch_instances(rng, n, 10_000)
        t0 = time.perf_counter()
        ro.project_radii_batch(C, R, S)
        t_batch = (time.perf_counter() - t0) / len(C)
        t0 = time.perf_counter()
        for k in range(1000):
            ro.project_radii(centers=C[k], radii=R[k], sigmas=S[k])
        t_loop = (time.perf_counter() - t0) / 1000
        print(f"| {n} | {len(C):,} | {fmt(t_batch)} | {fmt(t_loop)} | {1 / t_batch:,.0f} |")


if __name__ == "__main__":
    main()
