"""Benchmark: what a global query costs at 20, 100 and 1,000 tiles, beyond what this machine holds.

``cluster.py`` measures the global (no prior) query on a real site and saves the run time of every
tile task it ran (``<folder>-task-ms.npy``).  This script replays those times on Dask's own
scheduler: for each (tiles, workers) case, a ``distributed.LocalCluster`` of in-process workers
(one thread each) gets one task per tile, restricted to the tile's home worker as
``ClusterTiles`` does (tiles dealt round-robin): per query and worker, one task sleeping for the
summed task times of its tiles (drawn from the measured ones) and the summary task that reads it,
then one more task for the chosen answer.  The workers talk TCP over loopback, as separate
machines would.  A sleeping task holds its worker's thread but no core, so the replay shows what a
cluster with one core per worker would do: the scheduler's and the network stack's share comes on
top of the measured work, and the work itself is the measured tasks'.

One process cannot run the event loops of 150 workers (at 1,000 tiles on 150 workers the replay
spent its one core in the loops, not in the tasks), so the cases beyond ``--cases`` are a model,
each row marked: the makespan of the measured task times dealt over the workers, plus the replays'
time beyond their makespan fitted as a + b x workers.

Reported per case, from one run:

* latency p50 / p95 of one global query alone (``--queries`` of them, one after another), against
  the makespan of the query's tasks (the largest sum of task times on one worker: no scheduler
  can do better with the tiles where they are) and against the issue's ideal,
  1.5 x tiles x mean task / workers + 50 ms;
* what the cluster serves: a batch of ``--batch`` global queries submitted at once, in queries
  per second, and per worker in tile tasks per second.

Run:  cd benchmarks && python cluster_scaling.py --tasks /tmp/site2m-task-ms.npy
      [--cases 20x3,50x8,100x15] [--model 1000x150] [--queries 5] [--batch 8] [--seed 0]
Prints one Markdown table (progress on stderr).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _answers(seconds: float) -> float:
    time.sleep(seconds)
    return seconds


def _summaries(answers: float) -> float:
    return answers


def _query(client, workers: list[str], per_worker: np.ndarray) -> list:
    """One global query as ``ClusterTiles`` sends it: per worker, a task answering its tiles (here
    sleeping their summed task times) and the summary task that reads it; the futures of the
    summaries."""
    out = []
    for w, seconds in zip(workers, per_worker, strict=True):
        at = {"workers": [w], "allow_other_workers": False, "pure": False}
        answers = client.submit(_answers, float(seconds), **at)
        out.append(client.submit(_summaries, answers, **at))
    return out


def _per_worker(times: np.ndarray, n_workers: int) -> np.ndarray:
    """Each worker's summed task time, its tiles dealt round-robin."""
    return np.bincount(np.arange(len(times)) % n_workers, weights=times, minlength=n_workers)


def _case(n_tiles: int, n_workers: int, pool: np.ndarray, args: argparse.Namespace,
          rng: np.random.Generator) -> dict:
    import distributed

    with distributed.LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=False, protocol="tcp://",
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        client.wait_for_workers(n_workers, timeout=300)
        workers = sorted(client.scheduler_info()["workers"])
        client.gather(_query(client, workers, np.zeros(n_workers)))  # warm
        lat, span = [], []
        for _ in range(args.queries):
            per = _per_worker(rng.choice(pool, n_tiles) / 1e3, n_workers)
            t0 = time.perf_counter()
            client.gather(_query(client, workers, per))
            pick = client.submit(_summaries, 0.0, workers=[workers[0]], pure=False)  # the chosen answer
            pick.result()
            lat.append(time.perf_counter() - t0)
            span.append(float(per.max()))
        batch = [_per_worker(rng.choice(pool, n_tiles) / 1e3, n_workers) for _ in range(args.batch)]
        t0 = time.perf_counter()
        client.gather([f for per in batch for f in _query(client, workers, per)])
        batch_s = time.perf_counter() - t0
    mean = float(np.mean(pool)) / 1e3
    return {"lat": np.array(lat), "span": np.array(span), "ideal": 1.5 * n_tiles * mean / n_workers + 0.05,
            "qps": args.batch / batch_s, "tasks_per_worker": args.batch * n_tiles / batch_s / n_workers,
            "batch_span": float(np.sum(batch, axis=0).max())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", required=True, help="tile task times (ms) saved by cluster.py")
    ap.add_argument("--cases", default="20x3,50x8,100x15", help="replayed: tiles x workers, comma separated")
    ap.add_argument("--model", default="1000x150",
                    help="beyond the replays (one process cannot run that many workers' event loops): "
                         "the makespan of dealt measured times plus the replays' overhead fitted as "
                         "a + b x workers")
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
    print("| tiles | workers | | latency p50 / p95 | makespan p50 | ideal (1.5 x work / workers + 50 ms) "
          "| beyond the makespan, p50 | batch of queries: queries/s | tile tasks/s per worker |")
    print("|---:|---:|---|---|---:|---:|---:|---:|---:|")
    mean = float(np.mean(pool))
    fit_w, fit_over = [], []
    for case in args.cases.split(","):
        n_tiles, n_workers = (int(x) for x in case.lower().split("x"))
        log(f"{n_tiles} tiles on {n_workers} workers ...")
        r = _case(n_tiles, n_workers, pool, args, rng)
        lat, span = r["lat"] * 1e3, r["span"] * 1e3
        fit_w.append(n_workers)
        fit_over.append(float(np.median(lat - span)))
        print(f"| {n_tiles:,} | {n_workers} | replayed | {np.median(lat):.0f} / "
              f"{np.percentile(lat, 95):.0f} ms | "
              f"{np.median(span):.0f} ms | {r['ideal'] * 1e3:.0f} ms | {np.median(lat - span):.0f} ms | "
              f"{r['qps']:.2f} (makespan bound {args.batch / r['batch_span']:.2f}) | "
              f"{r['tasks_per_worker']:.1f} |")
    if args.model:
        # the replays' time beyond the makespan, a + b x workers (least squares), and the
        # makespan of dealt tiles drawn from the measured times
        b, a = np.polyfit(fit_w, fit_over, 1) if len(set(fit_w)) > 1 else (0.0, fit_over[0])
        for case in args.model.split(","):
            n_tiles, n_workers = (int(x) for x in case.lower().split("x"))
            spans = [_per_worker(rng.choice(pool, n_tiles), n_workers).max() for _ in range(200)]
            over = a + b * n_workers
            print(f"| {n_tiles:,} | {n_workers} | model | {np.median(spans) + over:.0f} ms (p50) | "
                  f"{np.median(spans):.0f} ms | {1.5 * n_tiles * mean / n_workers + 50:.0f} ms | "
                  f"{over:.0f} ms ({a:.1f} + {b:.2f} x workers) | "
                  f"{1e3 / (n_tiles * mean / n_workers):.2f} (work bound) | {1e3 / mean:.1f} |")


if __name__ == "__main__":
    main()
