"""Benchmark: how association and localisation scale from the kitchen to a 1M-object campus, with
every default and tuned, level and tilted.

Worlds (``--worlds``, default all): ``kitchen`` (scenes.kitchen, 753 objects), ``floor``
(scenes.floor(20000)), ``building`` (scenes.building_site: 5 storeys, 100k objects) and ``campus``
(scenes.campus_site: 10 buildings x 5 storeys, 1M objects).  Every world runs in its own
subprocess, so its peak memory (``VmHWM``, the ``ru_maxrss`` of this process alone) is its own:
after the imports, after the build and at the end.

Setups (``--setup``): ``defaults`` (the default) builds the building and the campus the way a
user with a map builds them, ``WorldModel.from_arrays(types, positions)`` with no flag (the
scene's own world is built first for its arrays and labels, so the build time and peak include
it), and calls everything with its defaults (``gravity="auto"``; far-pair indices built on first
use, those above 2M pairs left to the ring join); ``tuned`` uses the scenes' worlds as made and
builds the far-pair index (``WorldModel.build_far_pairs``) for every pair of types up front,
timed apart (``--no-far-index``: lazily instead).  ``--jitter S`` moves every building and campus
object by N(0, S^2) per axis: rooms alike but not identical (the scenes repeat their room modules
exactly, so that many views are honestly "ambiguous").  ``--tilts`` runs every world once per
tilt of the robot's ego z axis (degrees, about a random horizontal axis: a ramp, a head or base
that is not level); ``--imu`` adds, for every non-zero tilt, a run that passes the IMU's up
vector as ``gravity``.  The table says which search answered (gravity / free) and counts gross
confident-wrong answers (status "ok" more than 0.5 m or 10 degrees off).

For each of ``--poses`` random robot poses (kitchen: as in benchmarks/association.py, x, y
uniform 0.5 m inside the room, z = 1.5 m, percept types door/handle/drawer/knob; the others: at a
random table, 0.8 m above it, all types; in a building the robot sees its own storey only) the
robot sees 8 true percepts (random visible landmarks within 8 m) and 1 false one, with
``sigma = rho^2 / 1000`` (eq. 6), drawn with the helpers of benchmarks/association.py.  On the
same percepts it times ``associate`` and ``localize(method="ml")`` (and, for the building and
the campus, ``localize_tiled`` over storey or building tiles on the local processes of one
``TilePool``, forked on the first call and kept), and judges
the answer like benchmarks/association.py: correct = status "ok", 6D NEES <= 20.06 with the
returned covariance and rotation error <= 2 deg; the table counts the other answers too
(ambiguous, unique but wrong, failed; "weak" makes up the rest).

With ``--active``, the same percepts also go to ``active_localize`` (at most 2 looks where
``plan_view`` points, fov 60 deg; a look returns the true percepts of the robot's own landmarks
within 8 m and 30 deg of the gaze, from the true pose, with fresh noise and no false one), judged
the same way: repeated rooms and corridors leave one view ambiguous, a look at what differs
settles it.

Baselines on the same percepts (``--baselines``, by default on the kitchen only: their
candidate sets grow with the number of same-type objects): ``ransac``, this script's numpy
RANSAC over triples of same-type candidate correspondences (edge-length pre-check, Kabsch,
inliers within 4 sigma + 1 cm of a same-type object, refit on the inliers), and ``open3d``,
Open3D's ``registration_ransac_based_on_correspondence`` on the same candidates when
``import open3d`` works (``--open3d-path`` appends directories to ``sys.path`` for it).
Baselines give no covariance or status: correct = position error < 0.2 m and rotation error
<= 2 deg; the table gives this library's localize under that test too (any status with a pose).
Open3D runs RANSACConvergenceCriteria(1,000,000, 1.0): with (100,000, 0.999) it stopped early
(65 ms, 23 % correct on the kitchen's 30 views).
TEASER++ is not on PyPI (``pip download teaserpp-python`` finds nothing) and is not run.

Run:  python benchmarks/scaling.py [--worlds kitchen floor building campus] [--poses 50]
      [--setup defaults|tuned] [--tilts 0 3 15] [--imu] [--jitter 0.15] [--gravity]
      [--max-seconds 900] [--baselines ransac open3d]
Prints a Markdown table (progress on stderr).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parent))
import association as assoc_bench  # noqa: E402  (benchmarks/association.py: _draw, _judge, _pose)

from perception.simulation.simulate import simulate_percepts  # noqa: E402
from worldgraph import scenes  # noqa: E402
from worldgraph.active import active_localize  # noqa: E402
from worldgraph.association import AssociationTolerances, associate  # noqa: E402
from worldgraph.localization import localize  # noqa: E402
from worldgraph.model import WorldModel  # noqa: E402
from worldgraph.tiles import TilePool, localize_tiled, split  # noqa: E402

WORLDS = ("kitchen", "floor", "building", "campus")
N_TRUE, N_FALSE = 8, 1
LOOK_FOV_DEG = 60.0


def _maxrss_mib() -> float:
    """Peak resident memory of this process (MiB): ``VmHWM`` of /proc/self/status on Linux, which
    starts afresh at exec, unlike ``ru_maxrss`` (it keeps the launching parent's peak across
    fork and exec); ``ru_maxrss`` elsewhere."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0  # kB
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB on Linux


# ----------------------------------------------------------------------------------------------
# worlds and poses
# ----------------------------------------------------------------------------------------------
def _build(name: str, seed: int):  # noqa: ANN202 - (world, site or None)
    if name == "kitchen":
        return scenes.kitchen(seed=seed), None
    if name == "floor":
        return scenes.floor(n_objects=20000, seed=seed), None
    if name == "building":
        site = scenes.building_site(storeys=5, n_objects=100_000, seed=seed)
        return site.world, site
    site = scenes.campus_site(buildings=10, storeys=5, n_objects=1_000_000, seed=seed)
    return site.world, site


def _at_table(world, rng: np.random.Generator, tables: np.ndarray) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * np.pi)).as_matrix()
    m[:3, 3] = world.positions[tables[rng.integers(len(tables))]] + [0.0, 0.0, 0.8]
    return m


def _looker(world, mask: np.ndarray, pose: np.ndarray, rng: np.random.Generator, args: argparse.Namespace):
    """``look(direction)``: the true percepts (no false one) of the landmarks in ``mask`` that the
    robot at ``pose`` sees within 8 m and 30 deg of the ego direction (an active look)."""
    types, pos = list(world.types[mask]), world.positions[mask]
    cos_half = np.cos(np.radians(LOOK_FOV_DEG / 2))

    def look(d: np.ndarray) -> list:
        percepts, _ = simulate_percepts(types, pos, pose, rng, depth_factor=args.depth_factor,
                                        max_range=args.max_range)
        return [p for p in percepts if float(p.position @ d) >= cos_half * float(np.linalg.norm(p.position))]
    return look


def _tilted(pose_fn, tilt_deg: float):  # noqa: ANN202 - callable
    """``pose_fn`` with the ego z axis tilted by ``tilt_deg`` about a random horizontal axis (a
    robot on a ramp, a head or base that is not level: roll and pitch)."""
    if not tilt_deg:
        return pose_fn

    def tilted(rng: np.random.Generator) -> np.ndarray:
        m = pose_fn(rng)
        az = rng.uniform(0, 2 * np.pi)
        axis = np.array([np.cos(az), np.sin(az), 0.0])
        m[:3, :3] = m[:3, :3] @ Rotation.from_rotvec(np.radians(tilt_deg) * axis).as_matrix()
        return m
    return tilted


def _drawer(name: str, world, site, args: argparse.Namespace, tilt_deg: float = 0.0):  # noqa: ANN202
    """``draw(rng) -> (pose, percepts, mask)`` for the world; ``mask``: the landmarks the robot
    can see from there (the kitchen's percept types; in a building, its own storey); the robot's
    ego z axis tilted by ``tilt_deg``."""
    if name == "kitchen":
        mask = np.isin(world.types, assoc_bench.PERCEPT_TYPES)
        lo, hi = world.bounds
        kitchen_pose = _tilted(lambda r: assoc_bench._pose(r, lo, hi, 1.5), tilt_deg)
        return lambda rng: (*assoc_bench._draw(world, mask, rng, N_TRUE, N_FALSE, args, kitchen_pose)[:2],
                            mask)
    tables = np.flatnonzero(world.types == "table")
    if site is None:
        every = np.ones(len(world), dtype=bool)
        table_pose = _tilted(lambda r: _at_table(world, r, tables), tilt_deg)
        return lambda rng: (*assoc_bench._draw(world, every, rng, N_TRUE, N_FALSE, args, table_pose)[:2],
                            every)

    def draw(rng: np.random.Generator):  # noqa: ANN202
        # the robot sees the landmarks of its own storey (no percepts through the slabs)
        table = tables[rng.integers(len(tables))]
        mask = (site.storey == site.storey[table]) & (site.building == site.building[table])
        own = tables[mask[tables]]
        return (*assoc_bench._draw(world, mask, rng, N_TRUE, N_FALSE, args,
                                   _tilted(lambda r: _at_table(world, r, own), tilt_deg))[:2], mask)
    return draw


# ----------------------------------------------------------------------------------------------
# baselines
# ----------------------------------------------------------------------------------------------
def _candidates(world, percepts) -> tuple[np.ndarray, np.ndarray]:
    """Every same-type (percept, object) pair."""
    p_i, o_i = [], []
    for k, p in enumerate(percepts):
        objs = world.type_index.get(p.type, np.zeros(0, np.intp))
        p_i.append(np.full(len(objs), k))
        o_i.append(objs)
    return np.concatenate(p_i).astype(np.intp), np.concatenate(o_i).astype(np.intp)


def _kabsch(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Batched ``R, t`` with ``R a + t ~ b``; ``a, b (m, k, 3)``."""
    ca, cb = a.mean(axis=1), b.mean(axis=1)
    h = np.einsum("mki,mkj->mij", a - ca[:, None], b - cb[:, None])
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(np.einsum("mij,mjk->mik", vt.transpose(0, 2, 1), u.transpose(0, 2, 1))))
    s = np.ones((len(a), 3))
    s[:, 2] = d
    rot = np.einsum("mji,mj,mkj->mik", vt, s, u)
    return rot, cb - np.einsum("mij,mj->mi", rot, ca)


def ransac_baseline(world, percepts, rng: np.random.Generator, iterations: int = 200_000, batch: int = 5000
                    ) -> np.ndarray:
    """numpy RANSAC over triples of same-type candidate correspondences; ``world_from_ego``."""
    ego = np.array([p.position for p in percepts])
    sig = np.array([p.sigma for p in percepts])
    p_i, o_i = _candidates(world, percepts)
    pos = world.positions
    types = sorted({p.type for p in percepts})
    trees = {t: cKDTree(pos[world.type_index[t]]) for t in types}
    groups = {t: np.array([k for k, p in enumerate(percepts) if p.type == t]) for t in types}
    gate = 4.0 * sig + 0.01
    best, best_key = np.eye(4), (-1, np.inf)
    done = 0
    while done < iterations:
        pick = rng.integers(len(p_i), size=(batch, 3))
        pp, oo = p_i[pick], o_i[pick]
        ok = (pp[:, 0] != pp[:, 1]) & (pp[:, 0] != pp[:, 2]) & (pp[:, 1] != pp[:, 2])
        a, b = ego[pp], pos[oo]
        for u, v in ((0, 1), (0, 2), (1, 2)):  # edge-length check (Open3D's checker, 3 sigma)
            da = np.linalg.norm(a[:, u] - a[:, v], axis=1)
            db = np.linalg.norm(b[:, u] - b[:, v], axis=1)
            ok &= np.abs(da - db) < 3.0 * np.hypot(sig[pp[:, u]], sig[pp[:, v]]) + 0.01
        done += batch
        if not ok.any():
            continue
        rot, t = _kabsch(a[ok], b[ok])
        pred = np.einsum("mij,kj->mki", rot, ego) + t[:, None, :]
        dist = np.empty(pred.shape[:2])
        for typ, idx in groups.items():
            d, _ = trees[typ].query(pred[:, idx].reshape(-1, 3))
            dist[:, idx] = d.reshape(len(pred), len(idx))
        inl = dist < gate
        score = inl.sum(axis=1)
        err = np.where(inl, dist**2, 0.0).sum(axis=1)
        m = int(np.lexsort((err, -score))[0])
        if (score[m], -err[m]) > (best_key[0], -best_key[1]):
            best_key = (int(score[m]), float(err[m]))
            best = np.eye(4)
            best[:3, :3], best[:3, 3] = rot[m], t[m]
    # refit on the inliers of the best pose
    pred = ego @ best[:3, :3].T + best[:3, 3]
    src, dst = [], []
    for typ, idx in groups.items():
        d, j = trees[typ].query(pred[idx])
        keep = d < gate[idx]
        src.append(ego[idx][keep])
        dst.append(pos[world.type_index[typ][j[keep]]])
    src, dst = np.concatenate(src), np.concatenate(dst)
    if len(src) >= 3:
        rot, t = _kabsch(src[None], dst[None])
        best[:3, :3], best[:3, 3] = rot[0], t[0]
    return best


def open3d_baseline(world, percepts) -> np.ndarray:
    """Open3D's correspondence RANSAC on the same-type candidates; ``world_from_ego``."""
    import open3d as o3d

    reg = o3d.pipelines.registration
    ego = np.array([p.position for p in percepts])
    p_i, o_i = _candidates(world, percepts)
    src = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(ego))
    dst = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.array(world.positions)))
    corres = o3d.utility.Vector2iVector(np.column_stack([p_i, o_i]).astype(np.int32))
    max_sigma = max(p.sigma for p in percepts)
    result = reg.registration_ransac_based_on_correspondence(
        src, dst, corres, 4.0 * max_sigma + 0.01, reg.TransformationEstimationPointToPoint(False), 3,
        [reg.CorrespondenceCheckerBasedOnEdgeLength(0.9)], reg.RANSACConvergenceCriteria(1000000, 1.0))
    return np.asarray(result.transformation)


def _close(est: np.ndarray, pose: np.ndarray) -> bool:
    return bool(np.linalg.norm(est[:3, 3] - pose[:3, 3]) < 0.2 and assoc_bench._rot_err_deg(est, pose) <= 2.0)


# ----------------------------------------------------------------------------------------------
# one world (in its own subprocess)
# ----------------------------------------------------------------------------------------------
def _world(name: str, args: argparse.Namespace):  # noqa: ANN202 - (world, site or None)
    """The world of the setup: ``tuned``, the scene as made (the building and the campus flagged
    ``gravity_aligned``); ``defaults``, the building and the campus rebuilt the way a user with a
    map builds them, ``WorldModel.from_arrays(types, positions)`` with no flag (the kitchen is
    the scene as shipped).  ``--jitter`` moves every object of those two by N(0, jitter^2) per
    axis (rooms alike, not identical)."""
    world, site = _build(name, args.seed)
    if site is None or (args.setup == "tuned" and not args.jitter):
        return world, site
    pos = np.array(world.positions)
    if args.jitter:
        pos += np.random.default_rng([args.seed, 99]).normal(0.0, args.jitter, pos.shape)
    flat = WorldModel.from_arrays(world.types, pos, gravity_aligned=args.setup == "tuned")
    return flat, dataclasses.replace(site, world=flat)


def _runs(args: argparse.Namespace) -> list[tuple[float, bool]]:
    """(tilt in degrees, IMU up vector passed) of every run: each tilt with nothing passed, and
    with ``--imu`` each non-zero tilt with the up vector too."""
    return [(t, False) for t in args.tilts] + [(t, True) for t in args.tilts if t and args.imu]


def _gross(res, pose: np.ndarray) -> bool:
    """Status "ok" more than 0.5 m or 10 degrees from the truth."""
    return res.status == "ok" and bool(np.linalg.norm(res.position - pose[:3, 3]) > 0.5
                                       or assoc_bench._rot_err_deg(res.transformation, pose) > 10.0)


def run_world(name: str, args: argparse.Namespace) -> dict:
    rss_imports = _maxrss_mib()
    t0 = time.perf_counter()
    world, site = _world(name, args)
    build = time.perf_counter() - t0
    t0 = time.perf_counter()
    tuned = args.setup == "tuned"
    gravity = (world.gravity_aligned if args.gravity is None else args.gravity) or not tuned
    far = world.build_far_pairs(gravity) if args.far_index and tuned else 0
    index = time.perf_counter() - t0
    rss_build = _maxrss_mib()
    print(f"{name} ({args.setup}): {len(world)} objects built in {build:.1f} s, far-pair index {far:,} pairs "
          f"in {index:.1f} s, {rss_build:.0f} MiB", file=sys.stderr, flush=True)
    tol = AssociationTolerances(gravity_aligned=args.gravity) if tuned else None
    tiles = split(world, site.labels("storey" if name == "building" else "building")) \
        if site and args.tiled else None
    if tiles and args.far_index and tuned:  # each tile's world has its own index (built before the fork)
        t0 = time.perf_counter()
        for tile in tiles:
            tile.world.build_far_pairs(gravity)
        index += time.perf_counter() - t0
    # the tiles' worker processes are forked once, on the first call, and kept (TilePool)
    pool = TilePool(tiles, workers=args.workers) if tiles is not None else None
    runs = []
    extras: dict = {}
    for r, (tilt, imu) in enumerate(_runs(args)):
        first = r == 0
        runs.append(_run(name, world, site, args, tol, tilt, imu, pool if first else None,
                         tiles if first else None, extras if first else None))
    if pool is not None:
        pool.close()
    return {"world": name, "setup": args.setup, "objects": len(world), "build": build, "index": index,
            "far_pairs": far, "rss_imports": rss_imports, "rss_build": rss_build, "rss_peak": _maxrss_mib(),
            "runs": runs, "tiles": len(tiles) if tiles else 0, **extras}


def _stats(v: list[float]) -> list[float] | None:
    return [float(np.median(v)), float(np.percentile(v, 95))] if v else None


def _run(name: str, world, site, args: argparse.Namespace, tol, tilt: float, imu: bool, pool, tiles,
         extras: dict | None) -> dict:
    """One run of ``--poses`` views at one tilt; the first run also times the tiles, the active
    loop and the baselines (into ``extras``)."""
    draw = _drawer(name, world, site, args, tilt)
    rng = np.random.default_rng([args.seed + 17, int(round(10 * tilt))])
    t_assoc, t_loc, t_tiled, t_active, looks = [], [], [], [], []
    verdicts = {"good": 0, "tiled_good": 0, "active_good": 0, "close": 0, "gross": 0}
    kinds: dict = {"plain": {}, "tiled": {}}  # verdict -> count: good, ambiguous, weak, wrong, failed
    searches: dict = {}
    base = {b: {"time": [], "good": 0} for b in args.baselines if name in args.baseline_worlds} \
        if extras is not None else {}
    start = time.perf_counter()
    n = 0
    for k in range(args.poses):
        if time.perf_counter() - start > args.max_seconds:
            print(f"{name}: time budget reached after {n} poses", file=sys.stderr, flush=True)
            break
        pose, percepts, mask = draw(rng)
        # nothing passed ("auto"), or the IMU's up vector: the world's z axis in the ego frame
        how = {"gravity": pose[:3, :3].T @ np.array([0.0, 0.0, 1.0])} if imu else {}
        t = time.perf_counter()
        associate(world, percepts, tol, **how)
        t_assoc.append(time.perf_counter() - t)
        t = time.perf_counter()
        res = localize(world, percepts, tol=tol, **how)
        t_loc.append(time.perf_counter() - t)
        v = assoc_bench._judge(res, pose)
        verdicts["good"] += v == "good"
        verdicts["gross"] += _gross(res, pose)
        searches[res.search] = searches.get(res.search, 0) + 1
        # the baselines' test (any status with a finite pose), for the table beside them
        posed = bool(np.all(np.isfinite(res.transformation)))
        verdicts["close"] += posed and _close(res.transformation, pose)
        kinds["plain"][v] = kinds["plain"].get(v, 0) + 1
        if args.active and extras is not None:
            look_rng = np.random.default_rng([args.seed, k])
            t = time.perf_counter()
            act = active_localize(world, percepts, _looker(world, mask, pose, look_rng, args), max_looks=2,
                                  tol=tol, fov_deg=LOOK_FOV_DEG, max_range=args.max_range, **how)
            t_active.append(time.perf_counter() - t)
            looks.append(act.looks)
            va = assoc_bench._judge(act.result, pose)
            verdicts["active_good"] += va == "good"
            kinds.setdefault("active", {})[va] = kinds.get("active", {}).get(va, 0) + 1
        if tiles is not None:
            t = time.perf_counter()
            tr = localize_tiled(tiles, percepts, tol=tol, pool=pool, **how)
            t_tiled.append(time.perf_counter() - t)
            v = assoc_bench._judge(tr, pose)
            verdicts["tiled_good"] += v == "good"
            verdicts["gross"] += _gross(tr, pose)
            kinds["tiled"][v] = kinds["tiled"].get(v, 0) + 1
        for b, acc in base.items():
            t = time.perf_counter()
            est = ransac_baseline(world, percepts, rng) if b == "ransac" else open3d_baseline(world, percepts)
            acc["time"].append(time.perf_counter() - t)
            acc["good"] += _close(est, pose)
        n += 1
        print(f"{name} tilt {tilt:g}{' imu' if imu else ''} pose {k}: associate {t_assoc[-1] * 1e3:.0f} ms, "
              f"localize {t_loc[-1] * 1e3:.0f} ms {res.status} ({res.search})", file=sys.stderr, flush=True)
    if extras is not None:
        extras.update({"tiled": _stats(t_tiled), "tiled_correct": verdicts["tiled_good"] / max(n, 1),
                       "active": _stats(t_active), "looks": float(np.mean(looks)) if looks else 0.0,
                       "active_correct": verdicts["active_good"] / max(n, 1),
                       "baselines": {b: {"time": _stats(a["time"]), "correct": a["good"] / max(n, 1)}
                                     for b, a in base.items()}})
    return {"tilt": tilt, "imu": imu, "poses": n, "associate": _stats(t_assoc), "localize": _stats(t_loc),
            "correct": verdicts["good"] / max(n, 1), "close": verdicts["close"] / max(n, 1),
            "gross": verdicts["gross"], "searches": searches, "verdicts": kinds}


# ----------------------------------------------------------------------------------------------
# table
# ----------------------------------------------------------------------------------------------
def _ms(s: list[float] | None) -> str:
    return "-" if s is None else f"{s[0] * 1e3:,.1f} / {s[1] * 1e3:,.1f}"


def table(rows: list[dict]) -> str:
    kitchen = next((r for r in rows if r["world"] == "kitchen" and r.get("runs")
                    and r["runs"][0]["associate"]), None)
    k_assoc = kitchen["runs"][0]["associate"][0] if kitchen else None
    out = ["| world | setup | tilt | objects | build s (world + far-pair index: pairs) "
           "| peak MiB (imports / build / end) | poses "
           "| associate median / p95 ms | x kitchen | localize median / p95 ms | correct "
           "| ambiguous / wrong / failed | gross wrong ok | answered by gravity / free "
           "| tiled localize median / p95 ms (tiles) | tiled correct |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if "error" in r:
            out.append(f"| {r['world']} | - | - | - | - | - | - | {r['error']} |" + " - |" * 8)
            continue
        for i, run in enumerate(r["runs"]):
            ratio = f"{run['associate'][0] / k_assoc:.1f}x" if k_assoc and run["associate"] else "-"
            tiled = f"{_ms(r['tiled'])} ({r['tiles']})" if r["tiles"] and i == 0 else "-"
            tc = f"{100 * r['tiled_correct']:.0f} %" if r["tiles"] and i == 0 else "-"
            kv = run["verdicts"]["plain"]
            awf = " / ".join(str(kv.get(k, 0)) for k in ("ambiguous", "wrong", "failed"))
            tilt = f"{run['tilt']:g} deg" + (", IMU up" if run["imu"] else "")
            gf = f"{run['searches'].get('gravity', 0)} / {run['searches'].get('free', 0)}"
            head = (f"{r['objects']:,} | {r['build']:.2f} + {r['index']:.2f}: {r['far_pairs'] / 1e6:.1f}M | "
                    f"{r['rss_imports']:,.0f} / {r['rss_build']:,.0f} / {r['rss_peak']:,.0f}") if i == 0 \
                else '" | " | "'
            out.append(f"| {r['world']} | {r['setup']} | {tilt} | {head} | {run['poses']} "
                       f"| {_ms(run['associate'])} | {ratio} | {_ms(run['localize'])} "
                       f"| {100 * run['correct']:.0f} % | {awf} | {run['gross']} | {gf} | {tiled} | {tc} |")
    act = [r for r in rows if r.get("active")]
    if act:
        out += ["", "| world | active_localize median / p95 ms | looks (mean) | correct after <= 2 looks "
                "| ambiguous / wrong / failed |", "|---|---|---|---|---|"]
        for r in act:
            kv = r["runs"][0]["verdicts"].get("active", {})
            awf = " / ".join(str(kv.get(k, 0)) for k in ("ambiguous", "wrong", "failed"))
            out.append(f"| {r['world']} | {_ms(r['active'])} | {r['looks']:.2f} | "
                       f"{100 * r['active_correct']:.0f} % | {awf} |")
    base = [(r, b, a) for r in rows if "baselines" in r for b, a in r["baselines"].items()]
    if base:
        out += ["", "| world | method | median / p95 ms | within 0.2 m and 2 deg "
                "| correct: status ok, NEES, 2 deg |", "|---|---|---|---|---|"]
        for r in rows:
            if r.get("runs") and r["runs"][0].get("localize"):
                run = r["runs"][0]
                out.append(f"| {r['world']} | worldgraph localize (ml) | {_ms(run['localize'])} "
                           f"| {100 * run['close']:.0f} % | {100 * run['correct']:.0f} % |")
        for r, b, a in base:
            out.append(f"| {r['world']} | {b} | {_ms(a['time'])} | {100 * a['correct']:.0f} % | - |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--worlds", nargs="+", choices=WORLDS, default=list(WORLDS))
    ap.add_argument("--poses", type=int, default=50)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--setup", choices=("defaults", "tuned"), default="defaults",
                    help="defaults: the building and campus from bare arrays (WorldModel.from_arrays, no "
                         "flag), every call with its defaults; tuned: the scenes as made (gravity_aligned), "
                         "the far-pair index built up front")
    ap.add_argument("--tilts", type=float, nargs="+", default=[0.0],
                    help="degrees of ego roll/pitch (about a random horizontal axis), one run each")
    ap.add_argument("--imu", action="store_true",
                    help="also run every non-zero tilt with the IMU's up vector passed as gravity")
    ap.add_argument("--jitter", type=float, default=0.0,
                    help="metres: move every building/campus object by N(0, jitter^2) per axis")
    ap.add_argument("--gravity", action="store_true", default=None,
                    help="tuned setup: AssociationTolerances(gravity_aligned=True) in every world; "
                         "default: the call's gravity argument ('auto')")
    ap.add_argument("--max-seconds", type=float, default=900.0,
                    help="stop drawing poses for a world after this many seconds")
    ap.add_argument("--no-far-index", dest="far_index", action="store_false",
                    help="do not run WorldModel.build_far_pairs after the world (built lazily on first use)")
    ap.add_argument("--no-tiled", dest="tiled", action="store_false",
                    help="do not run localize_tiled (its tiles double the world's memory)")
    ap.add_argument("--workers", type=int, default=None, help="processes of localize_tiled")
    ap.add_argument("--active", action="store_true",
                    help="also run active_localize (at most 2 looks of plan_view, 60 deg, at the true pose)")
    ap.add_argument("--baselines", nargs="*", choices=("ransac", "open3d"), default=["ransac", "open3d"])
    ap.add_argument("--baseline-worlds", nargs="*", choices=WORLDS, default=["kitchen"])
    ap.add_argument("--open3d-path", default=None,
                    help="directories (os.pathsep-separated) appended to sys.path for open3d and its deps")
    ap.add_argument("--depth-factor", type=float, default=1000.0)
    ap.add_argument("--max-range", type=float, default=8.0)
    ap.add_argument("--hfov", type=float, default=None)
    ap.add_argument("--one", choices=WORLDS, help=argparse.SUPPRESS)  # internal: run one world, print JSON
    args = ap.parse_args(argv)
    if args.open3d_path:
        sys.path.extend(args.open3d_path.split(os.pathsep))
    if "open3d" in args.baselines:  # each world's subprocess checks again for itself
        try:
            import open3d  # noqa: F401
        except ImportError as exc:
            if not args.one:
                print(f"open3d baseline dropped: {exc}", file=sys.stderr)
            args.baselines = [b for b in args.baselines if b != "open3d"]
    if args.one:
        print(json.dumps(run_world(args.one, args)))
        return
    rows = []
    passthrough = [a for a in (argv if argv is not None else sys.argv[1:])]
    for name in args.worlds:
        cmd = [sys.executable, __file__, *passthrough, "--one", name]
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, text=True, env=os.environ.copy())
        lines = proc.stdout.strip().splitlines()
        if proc.returncode != 0 or not lines:
            rows.append({"world": name, "error": f"subprocess failed (exit {proc.returncode})"})
        else:
            rows.append(json.loads(lines[-1]))
        print(table(rows[-1:]), file=sys.stderr, flush=True)
    gravity = "gravity='auto'" if args.gravity is None else f"gravity_aligned={args.gravity}"
    print(f"{N_TRUE} true + {N_FALSE} false percepts, sigma = rho^2/{args.depth_factor:g}, max_range "
          f"{args.max_range:g} m, setup {args.setup}, {gravity}, jitter {args.jitter:g} m, "
          f"seed {args.seed}\n")
    print(table(rows))


if __name__ == "__main__":
    main()
