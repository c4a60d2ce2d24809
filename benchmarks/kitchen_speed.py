"""Benchmark: the kitchen case against TEASER++'s time, before and after a change.

The kitchen of ``benchmarks/scaling.py`` (``scenes.kitchen``, 753 objects) and its views: a robot
at 1.5 m, 8 true percepts of doors, handles, drawers and knobs within 8 m and 1 false one,
``sigma = rho^2 / 1000`` (``scaling._drawer``, seeds 17, 18, ...).  For each view it times
``associate(world, percepts)`` and ``localize(world, percepts)`` with every default (``--repeats``
passes over all views, the first one discarded as warm-up) and prints the medians, the 95th
percentiles and ``localize``'s own stage times (``LocalizationResult.timings``, medians).

``--against DIR`` also runs the same views with the library of another checkout (``DIR`` first
on ``PYTHONPATH``, in a subprocess; the two alternate pass by pass, so both see the same machine)
and checks that both give the same statuses, correspondences and poses (to 1e-6 m and rad): before
and after in one table.

Run:  python benchmarks/kitchen_speed.py [--views 40] [--repeats 4] [--against ../before]
Prints a Markdown table (progress on stderr).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
TEASER_ASSOCIATE_MS = 3.6  # TEASER++'s time on this association task
TARGET_LOCALIZE_MS = 8.0
STAGES = ("association", "validation", "radial", "position")


def _views(n: int) -> tuple:
    sys.path.insert(0, HERE)
    import scaling

    args = argparse.Namespace(jitter=0.0, max_range=8.0, depth_factor=1000.0, hfov=None)
    world, site = scaling._build("kitchen", 0)
    draw = scaling._drawer("kitchen", world, site, args, 0.0)
    rng = np.random.default_rng([17, 0])
    return world, [draw(rng)[:2] for _ in range(n)]


def one_pass(world, views) -> dict:
    """Times (s) of one pass over the views, the stages and the answers."""
    import worldgraph as wg

    out: dict = {"associate": [], "localize": [], "stages": {s: [] for s in STAGES}, "answers": []}
    for _, percepts in views:
        t = time.perf_counter()
        wg.associate(world, percepts)
        out["associate"].append(time.perf_counter() - t)
        t = time.perf_counter()
        res = wg.localize(world, percepts)
        out["localize"].append(time.perf_counter() - t)
        for s in STAGES:
            out["stages"][s].append(res.timings.get(s, 0.0))
        pose = res.transformation.tolist() if res.has_pose else None
        out["answers"].append([res.status, pose, [list(c) for c in res.correspondences]])
    return out


def child(n: int, passes: int) -> None:
    """Run in the other checkout: one JSON line per pass on stdout."""
    world, views = _views(n)
    for _ in range(passes):
        sys.stdin.readline()  # the parent's go: the two checkouts alternate
        print(json.dumps(one_pass(world, views)), flush=True)


def _merge(passes: list[dict]) -> dict:
    keep = passes[1:] if len(passes) > 1 else passes  # the first pass warms up
    out = {k: sum((p[k] for p in keep), []) for k in ("associate", "localize")}
    out["stages"] = {s: sum((p["stages"][s] for p in keep), []) for s in STAGES}
    out["answers"] = passes[-1]["answers"]
    return out


#: Two answers are the same when their statuses and correspondences are and their poses agree
#: to this (m and rad: a thousand times below any covariance the library reports).
POSE_AGREEMENT = 1e-6


def _same(a: list, b: list) -> int:
    """Number of views whose status, correspondences or pose (to :data:`POSE_AGREEMENT`) differ;
    an answer without correspondences (an older checkout's) is compared on the others."""
    bad = 0
    for ra, rb in zip(a, b, strict=True):
        (sa, pa), (sb, pb) = ra[:2], rb[:2]
        corr_differ = len(ra) > 2 and len(rb) > 2 and ra[2] != rb[2]
        if sa != sb or corr_differ or (pa is None) != (pb is None) or (
                pa is not None and not np.allclose(pa, pb, rtol=0.0, atol=POSE_AGREEMENT)):
            bad += 1
    return bad


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--views", type=int, default=40)
    ap.add_argument("--repeats", type=int, default=4, help="passes over the views (the first is warm-up)")
    ap.add_argument("--against", default=None, help="another checkout (its repository root)")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.views, args.repeats)
        return
    world, views = _views(args.views)
    proc = None
    if args.against:
        env = dict(os.environ, PYTHONPATH=os.path.abspath(args.against))
        cmd = [sys.executable, os.path.abspath(__file__), "--child", "--views", str(args.views),
               "--repeats", str(args.repeats)]
        proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env,
                                cwd=HERE)
    mine, theirs = [], []
    for k in range(args.repeats):
        if proc is not None:
            assert proc.stdin is not None and proc.stdout is not None
            proc.stdin.write("go\n")
            proc.stdin.flush()
            theirs.append(json.loads(proc.stdout.readline()))
        mine.append(one_pass(world, views))
        print(f"pass {k + 1} of {args.repeats}", file=sys.stderr, flush=True)
    if proc is not None:
        proc.wait()
    rows = [("this checkout", _merge(mine))]
    if theirs:
        rows.insert(0, (f"--against {args.against}", _merge(theirs)))
    print(table(rows, len(views), args.repeats))
    if theirs:
        differ = _same(rows[0][1]["answers"], rows[1][1]["answers"])
        print(f"\nStatuses, correspondences or poses ({POSE_AGREEMENT:g}) that differ between the two: "
              f"{differ} of {len(views)} views.")


def table(rows: list, n: int, repeats: int) -> str:
    ms = lambda v, q=50: 1000.0 * float(np.percentile(v, q))  # noqa: E731
    head = ("| library | associate median / p95 ms | localize median / p95 ms | "
            + " | ".join(f"{s} ms" for s in STAGES) + " |")
    out = [head, "|" + "---|" * (head.count("|") - 1)]
    for name, r in rows:
        out.append(f"| {name} | {ms(r['associate']):.1f} / {ms(r['associate'], 95):.1f} | "
                   f"{ms(r['localize']):.1f} / {ms(r['localize'], 95):.1f} | "
                   + " | ".join(f"{ms(r['stages'][s]):.2f}" for s in STAGES) + " |")
    if len(rows) == 2:
        a, b = rows[0][1], rows[1][1]
        out.append(f"| ratio | {np.median(a['associate']) / np.median(b['associate']):.2f}x | "
                   f"{np.median(a['localize']) / np.median(b['localize']):.2f}x | "
                   + " | ".join(f"{np.median(a['stages'][s]) / max(np.median(b['stages'][s]), 1e-12):.2f}x"
                                for s in STAGES) + " |")
    out.append("")
    out.append(f"{n} views x {repeats - 1} timed passes (medians over all); targets: associate <= "
               f"{TEASER_ASSOCIATE_MS} ms (TEASER++), localize <= {TARGET_LOCALIZE_MS} ms.")
    return "\n".join(out)


if __name__ == "__main__":
    main()
