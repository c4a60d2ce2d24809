"""Benchmark: the own vertex enumeration against pycddlib, float and exact.

For n = 3..7 Gaussian spheres (the restriction polytope of their radial space: ``C(n, 2) * 3``
inequalities in n dimensions), seeded instances in general position (random centres and radii)
and exactly degenerate ones (collinear centres, centres at one height, integer centres), this
times ``radialopt.vertices.enumerate_vertices`` (``method="auto"``), pycddlib's float mode
(``cdd``) and its exact rational mode (``cdd.gmp``, up to n = 6), and counts the instances where
a float result differs from the exact one (a vertex or ray farther than 1e-6, relative to the
right-hand side's scale, from every exact one, or the other way round).

pycddlib has no wheels on PyPI for Linux (``pip download --only-binary :all: pycddlib`` finds
nothing): it builds against cddlib and GMP, which README's test command installs with apt-get.

Run:  python benchmarks/vertex_enumeration.py [--instances 8] [--seed 0]
Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import time
from fractions import Fraction

import numpy as np
from scipy.spatial.distance import cdist

import radialopt as ro
from radialopt.vertices import enumerate_vertices

KINDS = ("general", "collinear", "one_height", "integer")
MATCH = 1e-6


def centres(kind: str, n: int, rng: np.random.Generator) -> np.ndarray:
    if kind == "collinear":
        return np.outer(rng.permutation(n) + rng.uniform(0, 0.5), rng.normal(size=3)) + rng.normal(size=3)
    if kind == "one_height":
        return np.column_stack([rng.uniform(0, 5, (n, 2)), np.full(n, 1.0)])
    if kind == "integer":
        grid = np.stack(np.meshgrid(*[np.arange(-3.0, 4.0)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
        return grid[rng.choice(len(grid), size=n, replace=False)]
    return rng.uniform(0, 5, (n, 3))


def instance(kind: str, n: int, rng: np.random.Generator):  # noqa: ANN201 - RestrictionPolytope
    c = centres(kind, n, rng)
    r = np.linalg.norm(c - rng.uniform(1, 4, 3), axis=1) + rng.normal(0, 0.05, n)
    return ro.RestrictionPolytope.from_spheres(ro.make_spheres(c, np.abs(r), 0.05))


def cdd_float(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    import cdd

    mat = cdd.matrix_from_array(np.hstack([b[:, None], -A]).tolist(), rep_type=cdd.RepType.INEQUALITY)
    gen = np.array(cdd.copy_generators(cdd.polyhedron_from_matrix(mat)).array, dtype=float)
    gen = gen.reshape(-1, A.shape[1] + 1)
    vert = np.abs(gen[:, 0] - 1.0) < 1e-9
    rays = gen[~vert, 1:]
    return gen[vert, 1:], rays / np.linalg.norm(rays, axis=1, keepdims=True).clip(1e-300)


def cdd_exact(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    import cdd
    import cdd.gmp as gmp

    rows = [[Fraction(float(bi))] + [-Fraction(float(a)) for a in row] for row, bi in zip(A, b, strict=True)]
    mat = gmp.matrix_from_array(rows, rep_type=cdd.RepType.INEQUALITY)
    gen = gmp.copy_generators(gmp.polyhedron_from_matrix(mat)).array
    verts = np.array([[float(Fraction(v) / Fraction(r[0])) for v in r[1:]]
                      for r in gen if Fraction(r[0]) != 0])
    rays = np.array([[float(v) for v in r[1:]] for r in gen if Fraction(r[0]) == 0]).reshape(-1, A.shape[1])
    return verts.reshape(-1, A.shape[1]), rays / np.linalg.norm(rays, axis=1, keepdims=True).clip(1e-300)


def _far(X: np.ndarray, Y: np.ndarray, tol: float) -> bool:
    if len(X) == 0 or len(Y) == 0:
        return len(X) != len(Y)
    D = cdist(X, Y)
    return bool(D.min(axis=0).max() > tol or D.min(axis=1).max() > tol)


def differs(got: tuple[np.ndarray, np.ndarray], exact: tuple[np.ndarray, np.ndarray], scale: float) -> bool:
    return _far(got[0], exact[0], MATCH * scale) or _far(got[1], exact[1], MATCH)


def best_of(f, reps: int = 3) -> float:  # noqa: ANN001
    out = np.inf
    for _ in range(reps):
        t0 = time.perf_counter()
        f()
        out = min(out, time.perf_counter() - t0)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--instances", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    print("| n | rows | kind | own median | cdd float median | float / own | cdd exact median | "
          "own differs from exact | cdd float differs from exact |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n in range(3, 8):
        for kind in KINDS:
            Ps = [instance(kind, n, rng) for _ in range(args.instances)]
            own = [best_of(lambda P=P: enumerate_vertices(P)) for P in Ps]
            flt = [best_of(lambda P=P: cdd_float(P.A, P.b)) for P in Ps]
            ex, bad_own, bad_flt = [], 0, 0
            if n <= 6:
                for P in Ps:
                    t0 = time.perf_counter()
                    exact = cdd_exact(P.A, P.b)
                    ex.append(time.perf_counter() - t0)
                    scale = max(1.0, float(np.abs(P.b).max()))
                    E = enumerate_vertices(P)
                    bad_own += differs((E.vertices, E.rays), exact, scale)
                    bad_flt += differs(cdd_float(P.A, P.b), exact, scale)
            ms = lambda v: f"{1e3 * float(np.median(v)):.2f} ms" if v else "-"  # noqa: E731
            counts = (f"{bad_own} / {len(Ps)} | {bad_flt} / {len(Ps)}" if ex else "- | -")
            print(f"| {n} | {Ps[0].A.shape[0]} | {kind} | {ms(own)} | {ms(flt)} | "
                  f"{np.median(flt) / np.median(own):.2f}x | {ms(ex)} | {counts} |")


if __name__ == "__main__":
    main()
