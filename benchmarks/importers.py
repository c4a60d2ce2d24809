"""Benchmark: a multi-storey map read from a GLB or OBJ file against the same objects as arrays.

For every ``--n`` (default 20,000 and 100,000 objects) it lays out a building of ``--storeys``
storeys (3.5 m apart) of 4 m x 5 m rooms, each with a door, a switch, a socket, a window, a
table with 2 to 4 chairs around it and sometimes a cabinet, positions jittered by a seeded
``np.random.default_rng`` and rounded to 1/256 m (so that the box corners are exact in the
float32 of a GLB and in the 8 decimals trimesh writes to an OBJ).  Every object is a box of
its type's size, one trimesh node named ``f"{type}_{k}"`` (``door_12``, ``chair_345``, ... so
the default type rule of :func:`worldgraph.importers.default_type_of` types it), placed by a
translation.  The scene is written to a temporary directory as GLB and as OBJ, then it times:

* ``write``: :func:`worldgraph.importers.write_scene` of the file (``trimesh.Scene.export``, GLB
  turned +Y up first);
* ``build``: ``WorldModel.from_file(path)`` (reading, typing and building the world), and
  ``WorldModel.from_arrays(types, positions, ids=..., sizes=...)`` of the same objects in the
  order the file gives them;
* ``peak`` / ``kept``: the peak and the retained memory of one more build under
  :mod:`tracemalloc` (Python allocations and numpy arrays; the ``from_file`` world keeps its
  trimesh scene);
* ``associate`` / ``localize``: medians over ``--poses`` robot poses (0.8 m above a random
  table, yaw uniform, seeing the objects of its own storey within 8 m: 8 true percepts with
  ``sigma = rho^2 / 1000`` from :func:`perception.simulation.simulate.simulate_percepts`), every world on
  the same percepts with ``tol=AssociationTolerances(gravity_aligned=True)``.

It checks that the worlds agree (same ids, types, positions and sizes, same association pairs
and the same localize poses) and says so under the table; nothing is asserted on the times.

Run:  python benchmarks/importers.py [--n 20000 100000] [--storeys 5] [--poses 20] [--seed 0]
      [--formats glb obj] [--no-memory]
(with ``PYTHONPATH=.`` from a worktree whose package is not the one pip installed).  The
100,000-object row takes several minutes (trimesh writes and reads one mesh per object).
Prints a Markdown table (progress on stderr).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
import tracemalloc
from collections.abc import Callable
from typing import Any

import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from perception.simulation.simulate import simulate_percepts
from worldgraph import AssociationTolerances, WorldModel, associate, localize
from worldgraph.importers import write_scene

STOREY_HEIGHT = 3.5
ROOM = (4.0, 5.0)
#: Box extents per type (metres, multiples of 1/128 so the half extents are multiples of 1/256).
SIZES = {
    "cabinet": (0.5, 0.4375, 1.75), "chair": (0.4375, 0.4375, 0.875), "door": (0.875, 0.0625, 2.0),
    "socket": (0.078125, 0.015625, 0.078125), "switch": (0.078125, 0.015625, 0.078125),
    "table": (1.25, 0.75, 0.0625), "window": (1.25, 0.125, 1.25),
}
Q = 256.0  # positions are multiples of 1/Q metres


def building(n: int, storeys: int = 5, seed: int = 0,
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(types (n,) str, positions (n, 3), sizes (n, 3), storey (n,))`` of a building of exactly
    ``n`` objects (the last rooms of the top storey cut)."""
    rng = np.random.default_rng(seed)
    per_room = 5 + 3 + 0.5  # door, switch, socket, window, table; 3 chairs on average; half a cabinet
    rooms_per_storey = max(1, math.ceil(1.1 * n / (storeys * per_room)))
    cols = max(1, round(math.sqrt(rooms_per_storey)))
    types: list[np.ndarray] = []
    pts: list[np.ndarray] = []
    order: list[np.ndarray] = []
    room = np.arange(storeys * rooms_per_storey)
    st, r = room // rooms_per_storey, room % rooms_per_storey
    x0, y0, z0 = (r % cols) * ROOM[0], (r // cols) * ROOM[1], st * STOREY_HEIGHT

    def add(t: str, rows: np.ndarray, xyz: np.ndarray) -> None:
        types.append(np.full(len(rows), t, dtype=object))
        pts.append(xyz)
        order.append(rows)

    add("door", room, np.column_stack([x0 + 0.6, y0 + 0.05, z0 + 1.0]))
    add("switch", room, np.column_stack([x0 + 1.2, y0 + 0.1, z0 + 1.1]))
    add("socket", room, np.column_stack([x0 + 3.0, y0 + 0.1, z0 + 0.3]))
    add("window", room, np.column_stack([x0 + 2.0, y0 + ROOM[1] - 0.1, z0 + 1.5]))
    tx, ty = x0 + 2.0 + rng.uniform(-0.4, 0.4, room.size), y0 + 2.5 + rng.uniform(-0.5, 0.5, room.size)
    add("table", room, np.column_stack([tx, ty, z0 + 0.74]))
    n_chairs = rng.integers(2, 5, room.size)
    owner = np.repeat(room, n_chairs)
    j = np.arange(owner.size) - np.repeat(np.cumsum(n_chairs) - n_chairs, n_chairs)
    ang = rng.uniform(0, 2 * np.pi, room.size)[owner] + 2 * np.pi * j / n_chairs[owner]
    add("chair", owner, np.column_stack([tx[owner] + 0.8 * np.cos(ang), ty[owner] + 0.8 * np.sin(ang),
                                         z0[owner] + 0.45]))
    cab = room[rng.random(room.size) < 0.5]
    add("cabinet", cab, np.column_stack([x0[cab] + 3.5, y0[cab] + 4.5, z0[cab] + 0.9]))
    rows = np.concatenate(order)
    keep = np.argsort(rows, kind="stable")[:n]
    if keep.size < n:  # pragma: no cover - sized with 10 % to spare
        raise RuntimeError(f"plan holds {keep.size} objects, fewer than {n}")
    t = np.concatenate(types)[keep]
    p = np.concatenate(pts)[keep]
    p = p + rng.normal(0.0, 0.02, p.shape) * [1.0, 1.0, 0.25]
    p = np.round(p * Q) / Q
    sizes = np.array([SIZES[x] for x in t.tolist()], dtype=np.float64)
    return t.astype(str), p, sizes, st[rows[keep]]


def scene_of(types: np.ndarray, positions: np.ndarray) -> trimesh.Scene:
    """One box node per object, named and keyed ``f"{type}_{k}"``, placed by a translation."""
    boxes = {t: trimesh.creation.box(extents=s) for t, s in SIZES.items()}
    scene = trimesh.Scene()
    for k, (t, p) in enumerate(zip(types.tolist(), positions, strict=True)):
        m = np.eye(4)
        m[:3, 3] = p
        name = f"{t}_{k}"
        scene.add_geometry(boxes[t], node_name=name, geom_name=name, transform=m)
    return scene


def _percepts(types: np.ndarray, positions: np.ndarray, storey: np.ndarray, rng: np.random.Generator,
              n_true: int = 8) -> tuple[np.ndarray, list]:
    """A pose 0.8 m above a random table and ``n_true`` percepts of its storey's objects."""
    tables = np.flatnonzero(types == "table")
    for _ in range(1000):
        table = tables[rng.integers(len(tables))]
        mask = storey == storey[table]
        pose = np.eye(4)
        pose[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * np.pi)).as_matrix()
        pose[:3, 3] = positions[table] + [0.0, 0.0, 0.8]
        percepts, _ = simulate_percepts(list(types[mask]), positions[mask], pose, rng, depth_factor=1000.0,
                                        max_range=8.0)
        if len(percepts) >= n_true:
            pick = rng.choice(len(percepts), n_true, replace=False)
            return pose, [percepts[i] for i in pick]
    raise RuntimeError("no pose with enough visible objects")


def _timed(fn: Callable[[], Any]) -> tuple[Any, float]:
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def _memory(fn: Callable[[], Any]) -> tuple[float, float]:
    """``(peak, retained)`` MiB of Python allocations while ``fn()`` runs and of what it returns."""
    tracemalloc.start()
    try:
        out = fn()
        current, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    del out
    return peak / 2**20, current / 2**20


def _run_queries(world: WorldModel, draws: list, tol: AssociationTolerances) -> dict[str, Any]:
    t_assoc, t_loc, pairs, poses = [], [], [], []
    for _pose, percepts in draws:
        hyps, dt = _timed(lambda p=percepts: associate(world, p, tol=tol))
        t_assoc.append(dt)
        pairs.append([tuple(h.pairs) for h in hyps])
        res, dt = _timed(lambda p=percepts: localize(world, p, tol=tol))
        t_loc.append(dt)
        poses.append((str(res.status), res.transformation.copy(), tuple(res.correspondences)))
    return {"assoc": float(np.median(t_assoc)), "loc": float(np.median(t_loc)), "pairs": pairs,
            "poses": poses}


def _same(a: dict[str, Any], b: dict[str, Any]) -> bool:
    if a["pairs"] != b["pairs"]:
        return False
    return all(sa == sb and ca == cb and np.allclose(ta, tb, atol=1e-9, equal_nan=True)
               for (sa, ta, ca), (sb, tb, cb) in zip(a["poses"], b["poses"], strict=True))


def _worlds_equal(w: WorldModel, ref: WorldModel) -> bool:
    return (np.array_equal(w.types, ref.types) and np.array_equal(w.positions, ref.positions)
            and [o.id for o in w.objects] == [o.id for o in ref.objects]
            and all(np.array_equal(w.objects[k].size, ref.objects[k].size)
                    for k in range(0, len(w), max(1, len(w) // 500))))


def run(n: int, args: argparse.Namespace, tmp: str) -> tuple[list[str], list[str]]:
    """Table rows and check notes for one building of ``n`` objects."""
    types, positions, sizes, storey = building(n, args.storeys, args.seed)
    rng = np.random.default_rng(args.seed + 1)
    draws = [_percepts(types, positions, storey, rng) for _ in range(args.poses)]
    tol = AssociationTolerances(gravity_aligned=True)
    rows, notes = [], []
    scene, t_scene = _timed(lambda: scene_of(types, positions))
    print(f"n={n}: scene of {len(scene.graph.nodes_geometry)} nodes in {t_scene:.1f} s", file=sys.stderr,
          flush=True)
    ref_order: np.ndarray | None = None
    ref_result: dict[str, Any] | None = None
    for fmt in args.formats:
        path = os.path.join(tmp, f"building_{n}.{fmt}")
        _, t_write = _timed(lambda p=path: write_scene(scene, p))  # glb: +Y up, as from_file reads it
        mib = os.path.getsize(path) / 2**20
        world, t_file = _timed(lambda p=path: WorldModel.from_file(p))
        # the same objects, in the order of the file's world, as arrays
        ids = [o.id for o in world.objects]
        order = np.array([int(i.rsplit("_", 1)[1]) for i in ids])
        ref, t_arrays = _timed(lambda o=order, i=ids: WorldModel.from_arrays(types[o], positions[o], ids=i,
                                                                            sizes=sizes[o]))
        if args.memory:
            peak_f, kept_f = _memory(lambda p=path: WorldModel.from_file(p))
            peak_a, kept_a = _memory(lambda o=order, i=ids: WorldModel.from_arrays(
                types[o], positions[o], ids=i, sizes=sizes[o]))
        else:
            peak_f = kept_f = peak_a = kept_a = math.nan
        rf = _run_queries(world, draws, tol)
        ra = _run_queries(ref, draws, tol)
        rows.append(f"| {n:,} | {fmt} ({mib:.0f} MB) | from_file | {t_write:.1f} | {t_file:.2f} "
                    f"| {peak_f:.0f} / {kept_f:.0f} | {1e3 * rf['assoc']:.1f} | {1e3 * rf['loc']:.1f} |")
        rows.append(f"| {n:,} | {fmt} | from_arrays | | {t_arrays:.2f} | {peak_a:.0f} / {kept_a:.0f} "
                    f"| {1e3 * ra['assoc']:.1f} | {1e3 * ra['loc']:.1f} |")
        for row in rows[-2:]:
            print(row, file=sys.stderr, flush=True)
        kind = type(world.objects).__name__
        notes.append(f"n={n:,} {fmt}: world.objects is {kind}; worlds equal (ids, types, positions, "
                     f"sizes): {_worlds_equal(world, ref)}; same association pairs and localize poses: "
                     f"{_same(rf, ra)}")
        if ref_order is not None and ref_result is not None:
            # the other format's world, compared through the original object numbers
            same_objects = np.array_equal(np.sort(order), np.sort(ref_order))
            notes.append(f"n={n:,} {fmt}: same objects as {args.formats[0]}: {same_objects}")
        ref_order, ref_result = order, rf
        del world, ref
    return rows, notes


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[20_000, 100_000], help="objects per building")
    ap.add_argument("--storeys", type=int, default=5)
    ap.add_argument("--poses", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--formats", nargs="+", default=["glb", "obj"], choices=["glb", "obj"])
    ap.add_argument("--no-memory", dest="memory", action="store_false",
                    help="skip the tracemalloc builds (they take as long again)")
    args = ap.parse_args(argv)
    rows: list[str] = []
    notes: list[str] = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.n:
            r, s = run(n, args, tmp)
            rows += r
            notes += s
    print(f"{args.storeys} storeys, {args.poses} poses, 8 true percepts within 8 m, sigma = rho^2/1000, "
          f"tol=AssociationTolerances(gravity_aligned=True), seed {args.seed}\n")
    print("| objects | file | build | write s | build s | peak / kept MiB | associate ms | localize ms |")
    print("|---:|---|---|---:|---:|---:|---:|---:|")
    print("\n".join(rows))
    print()
    print("\n".join(f"- {x}" for x in notes))


if __name__ == "__main__":
    main()
