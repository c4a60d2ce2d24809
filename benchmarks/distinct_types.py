"""Worlds of one object per type: ``WorldModel.from_arrays`` of N objects of N distinct
types, all at one point or spread out, and ``localize`` on them.

A GLB whose nodes are uniquely named gives such a world (one type per node); packed in one
place (the parts of one machine, or a test world at one point) every pair of objects is a link:
N (N - 1) / 2 links, one per type pair.  Such worlds take the enumeration of all pairs
(``_dense_links``); the column "pair search s" times the k-d tree's pair search and sorts
(``_tree_links``, the path they took before) on the same world.  Beyond ``MAX_LINKS`` (40M links:
10,000 objects at one point) the build is refused before the work, by a sample estimate.

"packed": uniform in a 2 m cube (every pair a link, as at one point, but no ties); "spread":
uniform in a ``2 sqrt(N)`` m square, 3 m high (about 5 objects within the 5 m link length of
each).  ``localize`` (method "ml") sees the 8 objects nearest to the middle of a packed or spread
world, from a robot 0.4 m away (sigma 2 cm), and 3 objects of the world at one point (coincident
landmarks: no pose can be fixed, so a failure status, never a pose).

    python benchmarks/distinct_types.py [--objects 1000 5000 10000] [--repeat 3]

Prints a Markdown table: the median build time of ``--repeat`` builds in this process.

Measured (``--repeat 3``, 2 shared cores: build times of 12.5M links vary between about 0.5 and
2.5 s from run to run with the machine's load; an earlier version took 4.0-4.5 s at 5,000
types at one point)::

    | layout | objects = types | links | build s | pair search s | localize | localize s |
    |---|---:|---:|---:|---:|---|---:|
    | one point | 1,000 | 499,500 | 0.05 | 0.07 | no_association (no pose) | 0.00 |
    | one point | 5,000 | 12,497,500 | 0.50 | 3.63 | no_association (no pose) | 0.00 |
    | one point | 10,000 | refused | 0.20 | - | WorldGraphError: ... 49,995,000 object pairs ... | - |
    | packed | 1,000 | 499,500 | 0.04 | 0.08 | weak, 0.014 m off | 0.01 |
    | packed | 5,000 | 12,497,500 | 0.48 | 4.18 | weak, 0.014 m off | 0.01 |
    | packed | 10,000 | refused | 0.24 | - | WorldGraphError: ... 49,995,000 object pairs ... | - |
    | spread | 1,000 | 8,530 | 0.02 | - | ok, 0.007 m off | 0.01 |
    | spread | 5,000 | 44,938 | 0.11 | - | ok, 0.010 m off | 0.01 |
    | spread | 10,000 | 90,770 | 0.22 | - | ok, 0.018 m off | 0.01 |

``world.graph`` (networkx) is not built here: 12.5M edges would take minutes and gigabytes.
"""

from __future__ import annotations

import argparse
import statistics
import time
from unittest import mock

import numpy as np
from scipy.spatial.transform import Rotation

import worldgraph as wg
from perception import Percept
from worldgraph.model import links as links_module


def _positions(n: int, layout: str, rng: np.random.Generator) -> np.ndarray:
    if layout == "one point":
        return np.tile([1.0, 2.0, 0.5], (n, 1))
    if layout == "packed":  # a 2 m cube: every pair within the 5 m link length
        return rng.uniform(0.0, 2.0, (n, 3))
    side = 2.0 * np.sqrt(n)
    return rng.uniform([0.0, 0.0, 0.0], [side, side, 3.0], (n, 3))


def _build(types: list[str], pos: np.ndarray, repeat: int, pair_search: bool = False
           ) -> tuple[float, wg.WorldModel | None, str]:
    """Median build seconds, the world, and the error's message when refused."""
    times = []
    world = None
    for _ in range(repeat):
        world = None  # the previous build's memory is free before the next
        t0 = time.perf_counter()
        try:
            if pair_search:
                with mock.patch.object(links_module, "_within_reach", lambda *a: False):
                    world = wg.WorldModel.from_arrays(types, pos)
            else:
                world = wg.WorldModel.from_arrays(types, pos)
        except wg.WorldGraphError as exc:
            return time.perf_counter() - t0, None, f"{type(exc).__name__}: {exc}"
        times.append(time.perf_counter() - t0)
    return statistics.median(times), world, ""


def _localize(world: wg.WorldModel, layout: str, rng: np.random.Generator) -> tuple[str, float]:
    pos = world.positions
    k = 3 if layout == "one point" else 8
    centre = pos[0] if layout == "one point" else pos.mean(axis=0)
    near = np.argsort(np.linalg.norm(pos - centre, axis=1))[:k]
    R = Rotation.from_euler("z", 0.4).as_matrix()
    t = centre + np.array([0.3, -0.2, 0.1])
    percepts = [Percept(str(world.types[i]), R.T @ (pos[i] - t) + 0.02 * rng.standard_normal(3), 0.02)
                for i in near]
    t0 = time.perf_counter()
    res = wg.localize(world, percepts)
    elapsed = time.perf_counter() - t0
    if res.has_pose:
        err = float(np.linalg.norm(res.position - t))
        return f"{res.status}, {err:.3f} m off", elapsed
    return f"{res.status} (no pose)", elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--objects", type=int, nargs="+", default=[1000, 5000, 10000])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--no-pair-search", action="store_true", help="skip the pair-search column")
    args = parser.parse_args()
    rng = np.random.default_rng(34)
    print("| layout | objects = types | links | build s | pair search s | localize | localize s |")
    print("|---|---:|---:|---:|---:|---|---:|")
    for layout in ("one point", "packed", "spread"):
        for n in args.objects:
            types = [f"part{k}" for k in range(n)]
            pos = _positions(n, layout, rng)
            seconds, world, refused = _build(types, pos, args.repeat)
            if world is None:
                print(f"| {layout} | {n:,} | refused | {seconds:.2f} | - | {refused[:150]} | - |", flush=True)
                continue
            links = len(world.links)  # one object per type: one link per linked type pair
            old = "-"
            if not args.no_pair_search and layout != "spread":
                old = f"{_build(types, pos, 1, pair_search=True)[0]:.2f}"
            status, loc_s = _localize(world, layout, rng)
            print(f"| {layout} | {n:,} | {links:,} | {seconds:.2f} | {old} | {status} | {loc_s:.2f} |",
                  flush=True)
            del world


if __name__ == "__main__":
    main()
