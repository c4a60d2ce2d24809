"""Benchmark: a map bigger than one process, served to many robots from a Dask cluster.

A site of ``--buildings`` office buildings (``worldgraph.scenes.building_site``, 5 storeys each,
``--objects`` in all, in a row 30 m apart) is written tile by tile, one tile per building: each
building is generated, its objects jittered by ``--jitter`` metres (rooms alike but not identical:
exact repeats leave about half of the views honestly ambiguous), written with
``worldgraph.tiles.save_tiles`` and let go, so no process holds the whole map. While a building is
in memory, ``--robots`` robots per building are drawn (a robot 0.8 m above a random table of the
building, random yaw, 8 true percepts within 8 m of its storey, sigma = rho^2 / 1000, 1 false
percept) and kept with their true poses.

Then a ``distributed.LocalCluster`` of ``--workers`` worker processes with ``--memory-limit``
each serves the folder through ``worldgraph.tiles.ClusterTiles``, and the table reports, from one
run:

* the client process's peak RSS while serving (psutil; the map never enters it);
* bytes over loopback per query (``psutil.net_io_counters(pernic=True)["lo"]``, sent + received,
  which counts both ends of every local connection, heartbeats included);
* query latency p50 / p95 (each robot with a position prior, ``--prior-radius``, as a WiFi fix
  gives: the pre-filter then visits the tiles that can see it), next to ``localize`` on the
  robot's own tile in one process (a
  separate process loads each tile file in turn: the reference never enters the client), and the
  tiles visited per query;
* throughput of 16 robots' queries through ``localize_many`` on a cluster of 2 workers against 1
  (on the tiles of those 16 robots, written to a second folder, so that one worker can hold
  them);
* a worker killed during a batch of queries: every answer still right, and the batch's time
  against the same batch undisturbed;
* correct (status "ok", 6D NEES <= 20.06 with the returned covariance, rotation <= 2 deg) and
  gross ("ok" and > 0.5 m or > 10 deg off) answers.

Run:  cd benchmarks && python cluster.py [--objects 2000000] [--buildings 10] [--workers 2]
      [--memory-limit 4GiB] [--robots 4] [--prior-radius 20] [--folder /tmp/site-tiles]
The table in docs/results/cluster.md: ``--objects 2400000 --buildings 12 --workers 3
--memory-limit 2GiB`` (the map, about 2.5 GB in memory, larger than any worker's limit).
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


def _reference(folder: str, robots: list, queue) -> None:
    """In a separate process: localize on each robot's own tile, loading one tile at a time."""
    import worldgraph as wg
    from worldgraph.tiles import load_tile, read_index

    index = read_index(folder)
    path = {e.label: e.path for e in index.tiles}
    times = []
    for b in sorted({r[0] for r in robots}):
        tile = load_tile(path[b])
        for rb, _, percepts in robots:
            if rb == b:
                t0 = time.perf_counter()
                wg.localize(tile.world, percepts)
                times.append(time.perf_counter() - t0)
        del tile
    queue.put(times)


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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", type=int, default=2_000_000)
    ap.add_argument("--buildings", type=int, default=10)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--memory-limit", default="4GiB")
    ap.add_argument("--robots", type=int, default=4, help="robots per building")
    ap.add_argument("--jitter", type=float, default=0.05,
                    help="object jitter (m): rooms alike, not identical")
    ap.add_argument("--folder", default="/tmp/worldgraph-site-tiles")
    ap.add_argument("--prior-radius", type=float, default=20.0,
                    help="each robot's position prior (a WiFi fix): a point within this many metres of "
                         "the truth and this radius; 0: no prior, every tile is a candidate")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    import dask
    import distributed

    # a worker holds its tiles as task results: never spill them to disk (pickling a tile of
    # 200k objects costs seconds); pausing and restarting at the limit stay as Dask sets them
    dask.config.set({"distributed.worker.memory.target": False, "distributed.worker.memory.spill": False})

    from worldgraph.tiles import ClusterTiles, read_index, save_tiles

    t0 = time.perf_counter()
    robots = write_site(args)
    write_s = time.perf_counter() - t0
    write_rss = psutil.Process().memory_info().rss
    total = sum(e.summary.n_objects for e in read_index(args.folder).tiles)
    log(f"site written: {total:,} objects, {len(robots)} robots, {write_s:.0f} s")

    ctx = multiprocessing.get_context("spawn")
    queue = ctx.Queue()
    ref = ctx.Process(target=_reference, args=(args.folder, robots, queue))
    ref.start()
    ref_times = np.array(queue.get())
    ref.join()

    rows: dict[str, str] = {}
    peak = 0
    rng = np.random.default_rng(args.seed)
    priors: list[dict] = []
    for _, pose, _ in robots:  # a WiFi fix: a point within prior_radius of the truth, and the radius
        prior = {}
        if args.prior_radius > 0:
            off = rng.normal(size=3) * [1.0, 1.0, 0.0]
            off *= rng.uniform(0.0, args.prior_radius) / max(float(np.linalg.norm(off)), 1e-9)
            prior = {"near": pose[:3, 3] + off, "radius": args.prior_radius}
        priors.append(prior)
    with distributed.LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                                  memory_limit=args.memory_limit, dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        t0 = time.perf_counter()
        remote = ClusterTiles(args.folder, client)
        remote.wait()
        load_s = time.perf_counter() - t0
        lat, sent, visited, verdicts = [], [], [], []
        for (_, pose, percepts), prior in zip(robots, priors, strict=True):
            before = _lo_bytes()
            t0 = time.perf_counter()
            res = remote.localize(percepts, **prior)
            lat.append(time.perf_counter() - t0)
            sent.append(_lo_bytes() - before)
            peak = max(peak, psutil.Process().memory_info().rss)
            visited.append(sum(v.visit for v in remote.plan(percepts, **prior)))
            verdicts.append(_verdict(res, pose))
        # a worker killed during a batch
        batch = [p for _, _, p in robots[:16]]
        where = _batch_priors(priors[:16])
        t0 = time.perf_counter()
        quiet = remote.localize_many(batch, **where)
        quiet_s = time.perf_counter() - t0
        worker = next(iter(client.scheduler_info()["workers"]))
        t0 = time.perf_counter()
        fut = client.submit(os._exit, 1, workers=[worker], pure=False)  # noqa: F841 - kills that worker
        noisy = remote.localize_many(batch, **where)
        noisy_s = time.perf_counter() - t0
        same = all(a.status == b.status and np.allclose(a.transformation, b.transformation, atol=1e-9)
                   for a, b in zip(quiet, noisy, strict=True))
        remote.close()
    # throughput: the 16 robots' tiles, 1 worker against args.workers
    sub = args.folder + "-batch"
    from worldgraph.tiles import load_tile
    labels = sorted({b for b, _, _ in robots[:16]})
    index = read_index(args.folder)
    save_tiles((load_tile(e.path) for e in index.tiles if e.label in labels), sub)
    through = {}
    for w in (1, 2):
        with distributed.LocalCluster(n_workers=w, threads_per_worker=1, processes=True,
                                      memory_limit=args.memory_limit, dashboard_address=None) as cluster, \
                distributed.Client(cluster) as client, ClusterTiles(sub, client) as remote:
            remote.wait()
            remote.localize_many(batch, **where)  # warm
            t0 = time.perf_counter()
            remote.localize_many(batch, **where)
            through[w] = len(batch) / (time.perf_counter() - t0)
    lat_ms, ref_ms = np.array(lat) * 1e3, ref_times * 1e3
    n = len(verdicts)
    rows["site"] = f"{total:,} objects in {args.buildings} tiles, written tile by tile in {write_s:.0f} s"
    rows["cluster"] = f"{args.workers} worker processes, memory limit {args.memory_limit} each"
    rows["tiles loaded on the workers"] = f"{load_s:.1f} s"
    rows["client peak RSS while serving"] = (f"{peak / 2**30:.2f} GiB (after writing: "
                                             f"{write_rss / 2**30:.2f} GiB)")
    rows["loopback bytes per query, median / max"] = f"{np.median(sent) / 1e6:.2f} / {max(sent) / 1e6:.2f} MB"
    rows["query latency p50 / p95"] = f"{np.median(lat_ms):.0f} / {np.percentile(lat_ms, 95):.0f} ms"
    rows["localize on the robot's own tile, one process, p50 / p95"] = (
        f"{np.median(ref_ms):.0f} / {np.percentile(ref_ms, 95):.0f} ms (target p50 <= "
        f"{1.5 * np.median(ref_ms) + 50:.0f} ms)")
    rows["tiles visited per query, median / max"] = (f"{np.median(visited):.0f} / {max(visited)} of "
                                                     f"{args.buildings}")
    rows["throughput, 16 robots, localize_many: 2 workers / 1"] = (
        f"{through[2]:.1f} / {through[1]:.1f} queries/s = {through[2] / through[1]:.2f}x")
    rows["a worker killed during a batch of 16"] = (f"answers {'all the same' if same else 'DIFFERENT'}, "
                                                    f"{noisy_s:.1f} s against {quiet_s:.1f} s undisturbed")
    rows["correct / gross 'ok'"] = (f"{100 * verdicts.count('correct') / n:.1f} % / "
                                    f"{verdicts.count('gross')} of {n} queries")
    print("| | |\n|---|---|")
    for k, v in rows.items():
        print(f"| {k} | {v} |")


if __name__ == "__main__":
    main()
