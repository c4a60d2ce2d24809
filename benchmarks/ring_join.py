"""Benchmark: the compiled ring join (worldgraph.model.ring_join.ring_pairs) against the k-d tree query.

Campus: buildings of 5 storeys 3.5 m apart, each storey 60 x 40 m holding about 2 objects per
m^2 (x, y uniform; z uniform in the storey's lowest ``--z-spread`` m, default 0.6), buildings
on a 100 m grid, as many as the size needs (24k objects each).  A and B are two independent
such sets of the same size.
Ring: horizontal distance in [5.9, 6.1] m, height offset b_z - a_z in [0.2, 0.4] m.

The k-d tree baseline is the current approach of worldgraph.association.consistency: z scaled by 10,
``cKDTree((A + (0, 0, dz)) * s).sparse_distance_matrix(cKDTree(B * s), radius)`` with
``dz`` the band's centre and ``radius = hypot(h_hi, 10 * z_halfwidth)`` (times 1 + 1e-9), then
the same exact filter.  Both must give the same pair set (checked on every size).

"first" is the first call in the process (ring: numba compile or cache load included), "warm"
the median of ``--repeats`` further calls.  ``--cells`` also times ring_pairs with a few cell
sizes (the default is h_hi / 4 = 1.525 m).

Run:  python benchmarks/ring_join.py [--sizes 20000 50000 100000 200000] [--repeats 3] [--cells]
Prints Markdown tables.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.spatial import cKDTree

from worldgraph.model.ring_join import ring_pairs

H_LO, H_HI = 5.9, 6.1
Z_LO, Z_HI = 0.2, 0.4
Z_SCALE = 10.0


def campus(n: int, rng: np.random.Generator, z_spread: float) -> np.ndarray:
    per_building = 5 * 60 * 40 * 2
    buildings = -(-n // per_building)
    side = int(np.ceil(np.sqrt(buildings)))
    which = rng.integers(0, buildings, n)
    storey = rng.integers(0, 5, n)
    pts = np.empty((n, 3))
    pts[:, 0] = (which % side) * 100.0 + rng.uniform(0.0, 60.0, n)
    pts[:, 1] = (which // side) * 100.0 + rng.uniform(0.0, 40.0, n)
    pts[:, 2] = storey * 3.5 + rng.uniform(0.0, z_spread, n)
    return pts


def keep(a: np.ndarray, b: np.ndarray, i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d = b[j] - a[i]
    h = np.hypot(d[:, 0], d[:, 1])
    ok = (h >= H_LO) & (h <= H_HI) & (d[:, 2] >= Z_LO) & (d[:, 2] <= Z_HI)
    return i[ok], j[ok]


def tree_pairs(a: np.ndarray, b: np.ndarray) -> tuple[tuple[np.ndarray, np.ndarray], int]:
    scale = np.array([1.0, 1.0, Z_SCALE])
    lift = np.array([0.0, 0.0, 0.5 * (Z_LO + Z_HI)])
    radius = np.hypot(H_HI, Z_SCALE * 0.5 * (Z_HI - Z_LO)) * (1.0 + 1e-9)
    hits = cKDTree((a + lift) * scale).sparse_distance_matrix(cKDTree(b * scale), radius,
                                                             output_type="ndarray")
    i, j = hits["i"].astype(np.int64), hits["j"].astype(np.int64)
    return keep(a, b, i, j), len(hits)


def timed(fn, repeats: int) -> tuple[float, float, object]:
    t0 = time.perf_counter()
    out = fn()
    first = time.perf_counter() - t0
    warm = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        warm.append(time.perf_counter() - t0)
    return first, float(np.median(warm)) if warm else first, out


def pair_set(i: np.ndarray, j: np.ndarray, m: int) -> np.ndarray:
    return np.unique(i.astype(np.int64) * m + j)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[20000, 50000, 100000, 200000])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--z-spread", type=float, default=0.6, help="object heights within a storey (m)")
    parser.add_argument("--cells", action="store_true", help="also time a few cell sizes")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    print(f"ring h in [{H_LO}, {H_HI}] m, dz in [{Z_LO}, {Z_HI}] m, z spread {args.z_spread} m; times in s\n")
    print("| n = m | pairs | tree hits/row | tree first | tree warm | ring first | ring warm | warm ratio |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    sets = []
    for n in args.sizes:
        a, b = campus(n, rng, args.z_spread), campus(n, rng, args.z_spread)
        sets.append((a, b))

        def ring(a=a, b=b):
            return ring_pairs(a, b, h_lo=H_LO, h_hi=H_HI, z_lo=Z_LO, z_hi=Z_HI)

        r_first, r_warm, (ri, rj) = timed(ring, args.repeats)
        t_first, t_warm, ((ti, tj), hits) = timed(lambda a=a, b=b: tree_pairs(a, b), args.repeats)
        if not np.array_equal(pair_set(ri, rj, n), pair_set(ti, tj, n)):
            raise SystemExit(f"n = {n}: ring_pairs and the k-d tree disagree")
        print(f"| {n} | {len(ri)} | {hits / n:.0f} | {t_first:.3f} | {t_warm:.3f} | {r_first:.3f} | "
              f"{r_warm:.3f} | {t_warm / r_warm:.1f}x |")
    if args.cells:
        cells = [0.25, 0.5, 0.75, 1.0, 1.5, 2.0]
        print("\nring_pairs warm median (s) by cell size (m)\n")
        print("| n = m | " + " | ".join(f"{c}" for c in cells) + " |")
        print("|---:|" + "---:|" * len(cells))
        for (a, b), n in zip(sets, args.sizes, strict=True):
            row = []
            for c in cells:
                _, warm, _ = timed(lambda a=a, b=b, c=c: ring_pairs(a, b, h_lo=H_LO, h_hi=H_HI, z_lo=Z_LO,
                                                                     z_hi=Z_HI, _cell=c), args.repeats)
                row.append(f"{warm:.3f}")
            print(f"| {n} | " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()
