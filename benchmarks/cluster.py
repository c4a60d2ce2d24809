"""Benchmark: a map bigger than one process, served to many robots from a Dask cluster.

A site of ``--buildings`` office buildings (``worldgraph.scenes.building_site``, 5 storeys each,
``--objects`` in all, in a row 30 m apart) is written tile by tile, one tile per building: each
building is generated, its objects jittered by ``--jitter`` metres (rooms alike but not identical:
exact repeats leave about half of the views honestly ambiguous), written with
``worldgraph.tiles.save_tiles`` and let go, so no process holds the whole map. While a building is
in memory, ``--robots`` robots per building are drawn (a robot 0.8 m above a random table of the
building, random yaw, 8 true percepts within 8 m of its storey, sigma = rho^2 / 1000, 1 false
percept) and kept with their true poses.

A separate process then loads each tile file in turn (nothing of the map enters the client) and
times the reference: ``localize`` of each robot on its own tile, and, for ``--global-queries``
robots spread over the buildings, the task a global query runs on every tile (one search, its
tilt checked, the ranking's fit cost), each alone in one process.

Then a ``distributed.LocalCluster`` of ``--workers`` worker processes with ``--memory-limit``
each serves the folder through ``worldgraph.tiles.ClusterTiles``, and the table reports, from one
run:

* the workers' RSS once the tiles are loaded, and the client process's peak RSS while serving;
* bytes over loopback per query (``psutil.net_io_counters(pernic=True)["lo"]``, sent + received,
  which counts both ends of every local connection, heartbeats included), and the bytes moved
  between workers (every worker's ``transfer_incoming_log``) over all queries;
* each robot's query with a position prior (``--prior-radius``, as a WiFi fix gives: the
  pre-filter then visits the tiles that can see it), and the ``--global-queries`` robots again
  without one (every tile is asked): latency p50 / p95 against the targets (with a prior, 1.5x
  the own tile + 50 ms; global, 1.5x tiles visited x own tile / workers + 50 ms) and against the
  work the query's tile tasks cost alone, over ``min(workers, cores)``; tiles visited; correct
  (status "ok", 6D NEES <= 20.06 with the returned covariance, rotation <= 2 deg) and gross ("ok"
  and > 0.5 m or > 10 deg off) answers;
* a worker SIGKILLed a third of the way into a batch of 16 global queries: every answer the
  same as the undisturbed batch's, and the batch's time against the undisturbed one plus the time
  to read the lost tiles' files;
* throughput of 16 robots' queries with priors through ``localize_many`` on a cluster of 2
  workers against 1 (on the tiles of those 16 robots, written to a second folder).

The reference's tile task times are saved to ``<folder>-task-ms.npy`` for
``cluster_scaling.py``.

Run:  cd benchmarks && python cluster.py [--objects 2000000] [--buildings 20] [--workers 3]
      [--memory-limit 2GiB] [--robots 2] [--global-queries 24] [--prior-radius 20]
      [--folder /tmp/worldgraph-site-tiles] [--reuse]
The table in docs/results/cluster.md: ``--objects 2000000 --buildings 20 --workers 3
--memory-limit 2GiB`` (the map, about 2.1 GB in memory, larger than any worker's limit).
Prints one Markdown table (progress on stderr).
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import sys
import time

import numpy as np
import psutil
from scipy.spatial.transform import Rotation

CHI2_6_3SIGMA = 20.06
GAP = 30.0  # metres between buildings


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _verdict(res, pose: np.ndarray) -> str:
    if res.status != "ok":
        return res.status
    e = np.concatenate([pose[:3, 3] - res.transformation[:3, 3],
                        Rotation.from_matrix(pose[:3, :3] @ res.transformation[:3, :3].T).as_rotvec()])
    dpos, drot = float(np.linalg.norm(e[:3])), float(np.degrees(np.linalg.norm(e[3:])))
    if dpos > 0.5 or drot > 10.0:
        return "gross"
    try:
        nees = float(e @ np.linalg.solve(res.pose_covariance, e))
    except np.linalg.LinAlgError:
        nees = np.inf
    return "correct" if nees <= CHI2_6_3SIGMA and drot <= 2.0 else "wrong"


def _robots(world, storeys: np.ndarray, rng: np.random.Generator, n: int) -> list:
    from perception.simulation.simulate import simulate_percepts

    tables = np.flatnonzero(world.types == "table")
    out = []
    while len(out) < n:
        table = tables[rng.integers(len(tables))]
        pose = np.eye(4)
        pose[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * np.pi)).as_matrix()
        pose[:3, 3] = world.positions[table] + [0.0, 0.0, 0.8]
        mask = storeys == storeys[table]
        percepts, truth = simulate_percepts(list(world.types[mask]), world.positions[mask], pose, rng,
                                            depth_factor=1000.0, max_range=8.0, n_false=1,
                                            false_types=sorted(set(world.types[mask])))
        true_idx = np.flatnonzero(truth >= 0)
        if len(true_idx) >= 8:
            pick = np.concatenate([rng.choice(true_idx, 8, replace=False), np.flatnonzero(truth < 0)])
            out.append((pose, [percepts[i] for i in rng.permutation(pick)]))
    return out


def write_site(args: argparse.Namespace) -> list:
    """Write the site tile by tile; return the robots ``(building, pose, percepts)``."""
    import worldgraph as wg
    from worldgraph import scenes
    from worldgraph.tiles import Tile, save_tiles

    per = args.objects // args.buildings
    robots: list = []
    offset = [0]
    x_next = [0.0]

    def tiles():
        for b in range(args.buildings):
            t0 = time.perf_counter()
            site = scenes.building_site(storeys=5, n_objects=per, seed=args.seed * 1000 + b)
            rng = np.random.default_rng([args.seed, b])
            lo, hi = site.world.bounds
            shift = np.array([x_next[0] - lo[0], 0.0, 0.0])  # in a row along x, GAP metres apart
            x_next[0] += float(hi[0] - lo[0]) + GAP
            jitter = rng.normal(0.0, args.jitter, site.world.positions.shape) * [1.0, 1.0, 0.0]
            pos = site.world.positions + shift + jitter
            world = wg.WorldModel.from_arrays(site.world.types, pos, gravity_aligned=True)
            drawn = _robots(world, np.asarray(site.storey), rng, args.robots)
            robots.extend((b, pose, p) for pose, p in drawn)
            index = np.arange(offset[0], offset[0] + len(world), dtype=np.intp)
            offset[0] += len(world)
            own = np.ones(len(world), dtype=bool)
            index.setflags(write=False)
            own.setflags(write=False)
            log(f"building {b}: {len(world):,} objects in {time.perf_counter() - t0:.1f} s, "
                f"RSS {psutil.Process().memory_info().rss / 2**30:.2f} GiB")
            yield Tile(world, index, b, own)

    save_tiles(tiles(), args.folder)
    return robots


def _reference(folder: str, robots: list, timed: list[int], queue) -> None:
    """In a separate process, loading one tile at a time: ``localize`` of each robot on its own
    tile, and the tile task a global query runs (one search, its tilt checked, the ranking's fit
    cost) of each robot in ``timed`` on every tile."""
    import worldgraph as wg
    from worldgraph.localization.settings import settings_of
    from worldgraph.tiles import load_tile, read_index
    from worldgraph.tiles.ranking import _run_tile, _TileQuery

    index = read_index(folder)
    types = frozenset(t for e in index.tiles for t in e.summary.type_counts)
    one = settings_of(None)
    own = np.zeros(len(robots))
    tasks = np.zeros((len(timed), len(index.tiles)))
    for k, entry in enumerate(index.tiles):
        tile = load_tile(entry.path)
        for r, (rb, _, percepts) in enumerate(robots):
            if rb == entry.label:
                t0 = time.perf_counter()
                wg.localize(tile.world, percepts)
                own[r] = time.perf_counter() - t0
        for row, r in enumerate(timed):
            t0 = time.perf_counter()
            _run_tile(tile.world, _TileQuery(robots[r][2], types, one))
            tasks[row, k] = time.perf_counter() - t0
        del tile
    queue.put((own, tasks))


def _batch_priors(priors: list[dict]) -> dict:
    """``localize_many``'s per-query ``near`` and ``radius`` (NaN rows: no prior)."""
    if not any(priors):
        return {}
    near = np.array([p.get("near", np.full(3, np.nan)) for p in priors])
    radius = np.array([p.get("radius", 1.0) for p in priors])
    return {"near": near, "radius": radius}


def _lo_bytes() -> int:
    c = psutil.net_io_counters(pernic=True).get("lo")
    return 0 if c is None else int(c.bytes_sent + c.bytes_recv)


def _queries(remote, robots: list, priors: list[dict]) -> dict:
    """Each robot's query one after another: latency, loopback bytes, tiles visited, verdicts."""
    out: dict = {"lat": [], "bytes": [], "visited": [], "verdicts": [], "peak": 0}
    for (_, pose, percepts), prior in zip(robots, priors, strict=True):
        before = _lo_bytes()
        t0 = time.perf_counter()
        res = remote.localize(percepts, **prior)
        out["lat"].append(time.perf_counter() - t0)
        out["bytes"].append(_lo_bytes() - before)
        out["peak"] = max(out["peak"], psutil.Process().memory_info().rss)
        out["visited"].append(sum(v.visit for v in remote.plan(percepts, **prior)))
        out["verdicts"].append(_verdict(res, pose))
    return out


def _kill_during(client, remote, batch: list, where: dict) -> tuple[float, float, bool, float]:
    """A batch undisturbed, then the same batch with one worker SIGKILLed a third of the way in:
    (undisturbed s, disturbed s, same answers, the killed worker's tiles' load s)."""
    import signal
    import threading

    t0 = time.perf_counter()
    quiet = remote.localize_many(batch, **where)
    quiet_s = time.perf_counter() - t0
    worker = sorted(client.scheduler_info()["workers"])[0]
    lost = [label for label, home in remote.homes.items() if home == worker]
    pid = client.run(os.getpid, workers=[worker])[worker]
    killer = threading.Timer(quiet_s / 3, os.kill, (pid, signal.SIGKILL))
    t0 = time.perf_counter()
    killer.start()
    noisy = remote.localize_many(batch, **where)
    noisy_s = time.perf_counter() - t0
    killer.join()
    same = all(a.status == b.status and np.allclose(a.transformation, b.transformation, atol=1e-9)
               for a, b in zip(quiet, noisy, strict=True))
    from worldgraph.tiles import load_tile

    path = {e.label: e.path for e in remote.index.tiles}
    t0 = time.perf_counter()
    for label in lost:
        load_tile(path[label])
    return quiet_s, noisy_s, same, time.perf_counter() - t0


def _site(args: argparse.Namespace) -> tuple[list, float]:
    """The site's robots (written now, or read back with ``--reuse``) and the write time."""
    import pickle

    from worldgraph.tiles import read_index

    saved = os.path.join(args.folder, "robots.pkl")
    if args.reuse and os.path.exists(saved):
        read_index(args.folder)
        with open(saved, "rb") as fh:
            return pickle.load(fh), float("nan")
    t0 = time.perf_counter()
    robots = write_site(args)
    with open(saved, "wb") as fh:
        pickle.dump(robots, fh)
    return robots, time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", type=int, default=2_000_000)
    ap.add_argument("--buildings", type=int, default=20)
    ap.add_argument("--workers", type=int, default=3)
    ap.add_argument("--memory-limit", default="2GiB")
    ap.add_argument("--robots", type=int, default=2, help="robots per building")
    ap.add_argument("--global-queries", type=int, default=24,
                    help="robots (spread over the buildings) asked again without a prior")
    ap.add_argument("--jitter", type=float, default=0.05,
                    help="object jitter (m): rooms alike, not identical")
    ap.add_argument("--folder", default="/tmp/worldgraph-site-tiles")
    ap.add_argument("--reuse", action="store_true", help="serve the folder a former run wrote")
    ap.add_argument("--prior-radius", type=float, default=20.0,
                    help="each robot's position prior (a WiFi fix): a point within this many metres of "
                         "the truth and this radius")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    import distributed

    from worldgraph.tiles import ClusterTiles, load_tile, read_index, save_tiles

    robots, write_s = _site(args)
    write_rss = psutil.Process().memory_info().rss
    total = sum(e.summary.n_objects for e in read_index(args.folder).tiles)
    log(f"site: {total:,} objects, {len(robots)} robots, written in {write_s:.0f} s")

    ctx = multiprocessing.get_context("spawn")
    queue = ctx.Queue()
    step = max(1, len(robots) // max(1, args.global_queries))
    timed = list(range(0, len(robots), step))[:args.global_queries]
    kidnapped = [robots[r] for r in timed]
    ref = ctx.Process(target=_reference, args=(args.folder, robots, timed, queue))
    ref.start()
    ref_times, task_s = queue.get()
    ref.join()
    log(f"own-tile reference: p50 {1e3 * np.median(ref_times):.0f} ms")

    rng = np.random.default_rng(args.seed)
    priors: list[dict] = []
    for _, pose, _ in robots:  # a WiFi fix: a point within prior_radius of the truth, and the radius
        off = rng.normal(size=3) * [1.0, 1.0, 0.0]
        off *= rng.uniform(0.0, args.prior_radius) / max(float(np.linalg.norm(off)), 1e-9)
        priors.append({"near": pose[:3, 3] + off, "radius": args.prior_radius})
    with distributed.LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                                  memory_limit=args.memory_limit, dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        t0 = time.perf_counter()
        remote = ClusterTiles(args.folder, client)
        remote.wait()
        load_s = time.perf_counter() - t0
        rss = client.run(lambda: psutil.Process().memory_info().rss)
        log(f"tiles loaded in {load_s:.1f} s")
        idle0, t_idle = _lo_bytes(), time.perf_counter()
        time.sleep(5.0)
        idle_rate = (_lo_bytes() - idle0) / (time.perf_counter() - t_idle)
        moved0 = sum(client.run(lambda dask_worker: sum(e["total"] for e in dask_worker.transfer_incoming_log)
                                ).values())
        prior_q = _queries(remote, robots, priors)
        log("prior queries done")
        global_q = _queries(remote, kidnapped, [{}] * len(kidnapped))
        log("global queries done")
        moved = sum(client.run(lambda dask_worker: sum(e["total"] for e in dask_worker.transfer_incoming_log)
                               ).values()) - moved0
        batch = [p for _, _, p in kidnapped[:16]]
        quiet_s, noisy_s, same, reload_s = _kill_during(client, remote, batch, {})
        log("kill done")
        remote.close()
    np.save(args.folder + "-task-ms.npy", (task_s * 1e3).ravel())
    # throughput: the tiles of 16 robots, 1 worker against 2, with their priors
    sub = args.folder + "-batch"
    labels = sorted({b for b, _, _ in robots[:16]})
    index = read_index(args.folder)
    save_tiles((load_tile(e.path) for e in index.tiles if e.label in labels), sub)
    batch16 = [p for _, _, p in robots[:16]]
    where = _batch_priors(priors[:16])
    through = {}
    for w in (1, 2):
        with distributed.LocalCluster(n_workers=w, threads_per_worker=1, processes=True,
                                      memory_limit=args.memory_limit, dashboard_address=None) as cluster, \
                distributed.Client(cluster) as client, ClusterTiles(sub, client) as remote:
            remote.wait()
            remote.localize_many(batch16, **where)  # warm
            t0 = time.perf_counter()
            remote.localize_many(batch16, **where)
            through[w] = len(batch16) / (time.perf_counter() - t0)

    ref_ms = ref_times * 1e3
    own = float(np.median(ref_ms))
    cores = os.cpu_count() or 1
    rows: list[tuple[str, str, str]] = []
    rows.append(("site", f"{total:,} objects in {args.buildings} tiles"
                 + ("" if np.isnan(write_s) else f", written tile by tile in {write_s:.0f} s"), ""))
    rows.append(("cluster", f"{args.workers} worker processes, memory limit {args.memory_limit} each, "
                 f"{cores} cores", ""))
    rows.append(("tiles loaded on the workers", f"{load_s:.1f} s; worker RSS then "
                 + ", ".join(f"{v / 2**30:.2f}" for v in sorted(rss.values())) + " GiB", ""))
    rows.append(("localize on the robot's own tile, one process, p50 / p95",
                 f"{own:.0f} / {np.percentile(ref_ms, 95):.0f} ms", ""))
    for name, q in (("with a 20 m prior", prior_q), ("global (no prior)", global_q)):
        lat = np.array(q["lat"]) * 1e3
        vis = float(np.median(q["visited"]))
        ideal = 1.5 * vis * own / args.workers + 50.0 if vis > 1 else 1.5 * own + 50.0
        n = len(q["verdicts"])
        rows.append((f"{name}: queries", f"{n}", ""))
        rows.append((f"{name}: tiles visited, median / max", f"{vis:.0f} / {max(q['visited'])}", ""))
        rows.append((f"{name}: latency p50 / p95", f"{np.median(lat):.0f} / {np.percentile(lat, 95):.0f} ms",
                     f"p50 <= {ideal:.0f} ms"))
        rows.append((f"{name}: loopback bytes per query, median / max",
                     f"{np.median(q['bytes']) / 1e6:.2f} / {max(q['bytes']) / 1e6:.2f} MB "
                     f"(idle cluster: {idle_rate / 1e3:.0f} kB/s)", "<= 1 MB"))
        if name.startswith("global"):
            task_ms = task_s * 1e3
            labels_all = [e.label for e in read_index(args.folder).tiles]
            is_own = np.array([[robots[r][0] == label for label in labels_all] for r in timed])
            work = task_ms.sum(axis=1)
            lanes = min(args.workers, cores)
            rows.append((f"{name}: one tile's task alone, p50: own tile / other tiles",
                         f"{np.median(task_ms[is_own]):.0f} / {np.median(task_ms[~is_own]):.0f} ms", ""))
            rows.append((f"{name}: the work of a query (its tile tasks alone, summed), p50",
                         f"{np.median(work):.0f} ms; over {lanes} cores {np.median(work) / lanes:.0f} ms",
                         f"1.5x + 50 ms: {1.5 * np.median(work) / lanes + 50:.0f} ms"))
            rows.append((f"{name}: latency / (work over {lanes} cores), p50",
                         f"{np.median(lat / (work / lanes)):.2f}", "<= 1.5"))
        rows.append((f"{name}: correct / gross 'ok'",
                     f"{q['verdicts'].count('correct')} / {q['verdicts'].count('gross')} of {n}", "0 gross"))
    rows.append(("bytes moved between workers, all queries", f"{moved:,}", "0"))
    rows.append(("client peak RSS while serving", f"{max(prior_q['peak'], global_q['peak']) / 2**30:.2f} GiB "
                 f"(after writing: {write_rss / 2**30:.2f} GiB)", "<= 1 GiB"))
    rows.append(("a worker killed during a batch of 16 global queries",
                 f"answers {'all the same' if same else 'DIFFERENT'}, {noisy_s:.1f} s against "
                 f"{quiet_s:.1f} s undisturbed; its tiles load in {reload_s:.1f} s",
                 f"<= {quiet_s + reload_s:.1f} s"))
    rows.append(("throughput, 16 robots with priors, localize_many: 2 workers / 1",
                 f"{through[2]:.1f} / {through[1]:.1f} queries/s = {through[2] / through[1]:.2f}x",
                 ">= 1.5x"))
    print("| measured | | target |\n|---|---|---|")
    for k, v, t in rows:
        print(f"| {k} | {v} | {t} |")


if __name__ == "__main__":
    main()
