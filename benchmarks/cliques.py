"""Benchmark: the compiled clique search (numba) against the Python search of
worldgraph.association.cliques.maximum_cliques, on the same graphs, with the same answer checked.

Graphs: k = 9 parts (percepts) of n vertices each, random sparse edges (about ``degree``
neighbours per vertex over all other parts, as (rows, cols) pairs), plus a planted clique of
size k on one random vertex per part.  Two searches per graph, with the association's defaults
(``max_nodes`` 50,000, ``max_cliques`` 2,000):

* find: ``min_size = stop_at = k`` (the association's search for the maximum size),
* enumerate: ``min_size = k - 2``, ``near_maximum = 1`` (the near-maximum cliques).

"first" is the process's first compiled call (numba compile, or load from its cache, included:
run twice to see both); "warm" the median of ``--repeats`` further calls; the ratio is
Python / compiled warm time from this one run.  ``--threshold`` also times both paths on small
graphs (bool matrices of density ``--density``, n = 1 ... 40 per part), the sizes around
worldgraph.association.cliques.COMPILED_MIN_VERTICES.

Run:  python benchmarks/cliques.py [--sizes 200 2000 20000] [--degrees 5 50] [--repeats 3] [--threshold]
Prints Markdown tables.
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
import time
from collections.abc import Iterator

import numpy as np

import worldgraph.association.cliques as cliques
from worldgraph.association.cliques import maximum_cliques

K = 9
MAX_NODES = 50_000
MAX_CLIQUES = 2_000


@contextlib.contextmanager
def path(name: str) -> Iterator[None]:
    saved = cliques.COMPILED_MIN_VERTICES
    cliques.COMPILED_MIN_VERTICES = 0 if name == "compiled" else 10**12
    try:
        yield
    finally:
        cliques.COMPILED_MIN_VERTICES = saved


def planted_graph(rng: np.random.Generator, n: int, degree: int) -> tuple[list[int], dict]:
    per_pair = max(1, n * degree // (K - 1))
    hidden = rng.integers(0, n, K)
    adjacency = {}
    for p, q in itertools.combinations(range(K), 2):
        rows = np.append(rng.integers(0, n, per_pair), hidden[p])
        cols = np.append(rng.integers(0, n, per_pair), hidden[q])
        adjacency[(p, q)] = (rows, cols)
    return [n] * K, adjacency


def dense_graph(rng: np.random.Generator, n: int, density: float) -> tuple[list[int], dict]:
    adjacency = {(p, q): rng.uniform(size=(n, n)) < density for p, q in itertools.combinations(range(K), 2)}
    return [n] * K, adjacency


def warm_time(sizes: list[int], adjacency: dict, kwargs: dict, repeats: int) -> tuple[float, object]:
    """The median time of ``repeats`` calls after a first one, and the answer."""
    out = maximum_cliques(sizes, adjacency, **kwargs)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        maximum_cliques(sizes, adjacency, **kwargs)
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


def compare(sizes: list[int], adjacency: dict, kwargs: dict, repeats: int) -> tuple[float, float, object]:
    """Warm times of the Python search and of the compiled one; their answers must be equal."""
    with path("python"):
        slow_t, slow = warm_time(sizes, adjacency, kwargs, repeats)
    with path("compiled"):
        fast_t, fast = warm_time(sizes, adjacency, kwargs, repeats)
    assert fast == slow
    return slow_t, fast_t, fast


SEARCHES = {
    "find": {"min_size": K, "stop_at": K, "max_nodes": MAX_NODES},
    "enumerate": {"min_size": K - 2, "near_maximum": 1, "max_nodes": MAX_NODES, "max_cliques": MAX_CLIQUES},
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[200, 2000, 20000])
    parser.add_argument("--degrees", type=int, nargs="+", default=[5, 50])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--threshold", action="store_true")
    parser.add_argument("--density", type=float, default=0.3)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)

    t0 = time.perf_counter()
    with path("compiled"):
        first_call = maximum_cliques([2, 2], {(0, 1): None})
    first_ms = 1e3 * (time.perf_counter() - t0)
    assert first_call.maximum == 2
    print(f"first compiled call in this process (numba import + compile or cache load): {first_ms:.0f} ms\n")

    print(f"k = {K} parts, planted {K}-clique, max_nodes {MAX_NODES}, max_cliques {MAX_CLIQUES}\n")
    print("| n per part | degree | search | nodes | complete | cliques | Python ms | compiled ms | ratio |")
    print("|---:|---:|---|---:|---:|---:|---:|---:|---:|")
    for n, degree in itertools.product(args.sizes, args.degrees):
        sizes, adjacency = planted_graph(rng, n, degree)
        for name, kwargs in SEARCHES.items():
            slow_t, fast_t, fast = compare(sizes, adjacency, kwargs, args.repeats)
            print(f"| {n:,} | {degree} | {name} | {fast.nodes:,} | {fast.complete} | {len(fast.cliques)} | "
                  f"{1e3 * slow_t:.1f} | {1e3 * fast_t:.2f} | {slow_t / fast_t:.1f} |")

    if args.threshold:
        print(f"\nsmall graphs: k = {K}, bool matrices of density {args.density}, search as 'enumerate' "
              f"with min_size 3 (COMPILED_MIN_VERTICES = {cliques.COMPILED_MIN_VERTICES})\n")
        print("| n per part | vertices | nodes | Python ms | compiled ms | ratio |")
        print("|---:|---:|---:|---:|---:|---:|")
        kwargs = {"min_size": 3, "near_maximum": 1, "max_nodes": MAX_NODES, "max_cliques": MAX_CLIQUES}
        for n in (1, 2, 3, 4, 6, 8, 12, 16, 24, 40):
            sizes, adjacency = dense_graph(rng, n, args.density)
            slow_t, fast_t, fast = compare(sizes, adjacency, kwargs, max(args.repeats, 5))
            print(f"| {n} | {K * n} | {fast.nodes:,} | {1e3 * slow_t:.2f} | {1e3 * fast_t:.2f} | "
                  f"{slow_t / fast_t:.1f} |")


if __name__ == "__main__":
    main()
