"""Benchmark: what a global query costs at 20, 100 and 1,000 tiles, beyond what this machine holds.

``cluster.py`` measures the global (no prior) query on a real site and saves the run time of every
tile task it ran (``<folder>-task-ms.npy``).  This script replays those times on Dask's own
scheduler: for each (tiles, workers) case, a ``distributed.LocalCluster`` of in-process workers
(one thread each) gets one task per tile, restricted to the tile's home worker as
``ClusterTiles`` does (tiles spread round-robin), each task sleeping for a task time drawn from the
measured ones.  A sleeping task holds its worker's thread but no core, so the replay shows what a
cluster with one core per worker would do: the scheduler's and the network stack's share comes on
top of the measured work, and the work itself is the measured tasks'.

Reported per case, from one run:

* latency p50 / p95 of one global query alone (``--queries`` of them, one after another), against
  the makespan of the query's tasks (the largest sum of task times on one worker: no scheduler
  can do better with the tiles where they are) and against the issue's ideal,
  1.5 x tiles x mean task / workers + 50 ms;
* what the cluster serves: a batch of ``--batch`` global queries submitted at once, in queries
  per second, and per worker in tile tasks per second.

Run:  cd benchmarks && python cluster_scaling.py --tasks /tmp/site2m-task-ms.npy
      [--cases 20x3,100x15,1000x150] [--queries 5] [--batch 8] [--seed 0]
Prints one Markdown table (progress on stderr).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _task(seconds: float) -> float:
    time.sleep(seconds)
    return seconds


def _query(client, homes: list[str], times: np.ndarray) -> list:
    return [client.submit(_task, float(t), workers=[h], allow_other_workers=False, pure=False)
            for h, t in zip(homes, times, strict=True)]


def _case(n_tiles: int, n_workers: int, pool: np.ndarray, args: argparse.Namespace,
          rng: np.random.Generator) -> dict:
    import distributed

    with distributed.LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        client.wait_for_workers(n_workers, timeout=300)
        workers = sorted(client.scheduler_info()["workers"])
        homes = [workers[k % n_workers] for k in range(n_tiles)]
        client.gather(_query(client, homes, np.zeros(n_tiles)))  # warm
        lat, span = [], []
        for _ in range(args.queries):
            times = rng.choice(pool, n_tiles) / 1e3
            per_worker = np.bincount(np.arange(n_tiles) % n_workers, weights=times, minlength=n_workers)
            t0 = time.perf_counter()
            client.gather(_query(client, homes, times))
            lat.append(time.perf_counter() - t0)
            span.append(float(per_worker.max()))
        batch_times = [rng.choice(pool, n_tiles) / 1e3 for _ in range(args.batch)]
        t0 = time.perf_counter()
        futures = [f for times in batch_times for f in _query(client, homes, times)]
        client.gather(futures)
        batch_s = time.perf_counter() - t0
    mean = float(np.mean(pool)) / 1e3
    return {"lat": np.array(lat), "span": np.array(span), "ideal": 1.5 * n_tiles * mean / n_workers + 0.05,
            "qps": args.batch / batch_s, "tasks_per_worker": args.batch * n_tiles / batch_s / n_workers,
            "batch_span": sum(float(np.bincount(np.arange(n_tiles) % n_workers, weights=t,
                                                minlength=n_workers).max()) for t in batch_times)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", required=True, help="tile task times (ms) saved by cluster.py")
    ap.add_argument("--cases", default="20x3,100x15,1000x150", help="tiles x workers, comma separated")
    ap.add_argument("--queries", type=int, default=5)
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    pool = np.load(args.tasks)
    if pool.ndim != 1 or len(pool) == 0 or not np.all(np.isfinite(pool)) or np.any(pool < 0):
        raise SystemExit(f"--tasks {args.tasks}: expected a non-empty 1-D array of task times in ms")
    rng = np.random.default_rng(args.seed)
    print(f"Replayed {len(pool)} measured tile task times (p50 {np.median(pool):.0f} ms, mean "
          f"{np.mean(pool):.0f} ms) from {args.tasks}.\n")
    print("| tiles | workers | latency p50 / p95 | makespan p50 | ideal (1.5 x work / workers + 50 ms) "
          "| beyond the makespan, p50 | batch of queries: queries/s | tile tasks/s per worker |")
    print("|---:|---:|---|---:|---:|---:|---:|---:|")
    for case in args.cases.split(","):
        n_tiles, n_workers = (int(x) for x in case.lower().split("x"))
        log(f"{n_tiles} tiles on {n_workers} workers ...")
        r = _case(n_tiles, n_workers, pool, args, rng)
        lat, span = r["lat"] * 1e3, r["span"] * 1e3
        print(f"| {n_tiles:,} | {n_workers} | {np.median(lat):.0f} / {np.percentile(lat, 95):.0f} ms | "
              f"{np.median(span):.0f} ms | {r['ideal'] * 1e3:.0f} ms | {np.median(lat - span):.0f} ms | "
              f"{r['qps']:.2f} (makespan bound {args.batch / r['batch_span']:.2f}) | "
              f"{r['tasks_per_worker']:.1f} |")


if __name__ == "__main__":
    main()
