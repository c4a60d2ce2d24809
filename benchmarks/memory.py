"""Memory at scale: each input that once blew up, at 10x the size that failed.

Every case runs in its own subprocess under an address-space cap (default 3 GiB, as the audit
used), so a blow-up is a recorded failure and not a dead benchmark. The table gives the outcome
(the value returned or the package error raised), the child's peak resident memory (its own
``ru_maxrss``, interpreter and imports included) and its time.

    python benchmarks/memory.py                 # all cases at 10x the failing size
    python benchmarks/memory.py --scale 0.1     # quick look at a tenth of those sizes
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

#: case -> (size at 10x the failing one, what failed before, the code run in the child)
CASES: dict[str, tuple[int, str, str]] = {
    "fuse_percepts": (
        100_000,
        "10,000 percepts: (n, n, 3) array",
        """
import numpy as np, perception as pc
rng = np.random.default_rng(0)
centres = rng.uniform(-20, 20, (N // 10, 3))
pts = np.repeat(centres, 10, axis=0) + rng.normal(0, 0.01, (N, 3))
ps = [pc.Percept("handle", p, 0.01) for p in pts]
out = pc.fuse_percepts(ps, min_views=2)
result = f"{len(out)} fused percepts"
""",
    ),
    "fuse_percepts one blob": (
        100_000,
        "(new) 20,000 percepts within a few bandwidths: quadratic kernel sums, minutes",
        """
import numpy as np, perception as pc
pts = np.random.default_rng(0).normal(0, 0.05, (N, 3))
try:
    out = pc.fuse_percepts([pc.Percept("handle", p, 0.01) for p in pts], min_views=1)
    result = f"{len(out)} fused percepts"
except pc.PerceptionError as exc:
    result = type(exc).__name__
""",
    ),
    "from_arrays coincident": (
        300_000,
        "30,000 same-type objects at one point: every pair listed",
        """
import numpy as np, worldgraph as wg
try:
    wg.WorldModel.from_arrays(["door"] * N, np.zeros((N, 3)))
    result = "accepted (wrong)"
except wg.WorldGraphError as exc:
    result = type(exc).__name__
""",
    ),
    "from_arrays dense links": (
        200_000,
        "(audit) 20,000 objects of one type in a 10 m cube: 56 million links, MemoryError",
        """
import numpy as np, worldgraph as wg
rng = np.random.default_rng(0)
try:
    w = wg.WorldModel.from_arrays(["door"] * N, rng.uniform(0, 10, (N, 3)))
    result = f"{len(w.objects)} objects (wrong: too many links)"
except wg.WorldGraphError as exc:
    result = type(exc).__name__
""",
    ),
    "from_arrays many types": (
        30_000,
        "3,000 types: one link table per type pair",
        """
import numpy as np, worldgraph as wg
rng = np.random.default_rng(0)
types = [f"type{k}" for k in range(N)]
world = wg.WorldModel.from_arrays(types, rng.uniform(0, 200, (N, 3)))
result = f"{len(world.objects)} objects"
""",
    ),
    "from_arrays part types": (
        5_000,
        "(at the size that once failed) 5,000 types, one per object (CAD node names) in a 50 m cube: "
        "12.5M link tables, 42.6 s and 1.2 GB",
        """
import numpy as np, worldgraph as wg
rng = np.random.default_rng(0)
pos = rng.uniform(0, 50, (N, 3))
world = wg.WorldModel.from_arrays([f"part{k}" for k in range(N)], pos)
result = f"{len(world.type_index)} types, {len(world.links)} link tables"
""",
    ),
    "build_far_pairs part types": (
        5_000,
        "(at the size that once failed) the 5,000-type world above: every one of 12.5M type pairs "
        "estimated, and the held pairs summed at each build",
        """
import numpy as np, worldgraph as wg
rng = np.random.default_rng(0)
pos = rng.uniform(0, 50, (N, 3))
world = wg.WorldModel.from_arrays([f"part{k}" for k in range(N)], pos)
held = world.build_far_pairs()
result = f"{held} pairs in {sum(v is not None for v in world._far_pairs.values())} indices"
""",
    ),
    "mirror check": (
        1_200,
        "max_search_percepts=120: O(C(m, 4)) quadruples",
        """
import numpy as np, perception as pc, worldgraph as wg
rng = np.random.default_rng(0)
world = wg.scenes.kitchen(seed=0)
objs = world.objects
pick = rng.choice(len(objs), size=min(100, len(objs)), replace=False)
ps = [pc.Percept(objs[k].type, objs[k].position + rng.normal(0, 0.01, 3), 0.02) for k in pick]
tol = wg.AssociationTolerances(max_search_percepts=N)
res = wg.localize(world, ps, tol=tol, rng=rng)
result = f"status {res.status}"
""",
    ),
}

CHILD = """
import resource, sys, time
resource.setrlimit(resource.RLIMIT_AS, ({cap}, {cap}))
N = {n}
t0 = time.perf_counter()
try:
{body}
except MemoryError:
    result = "MemoryError"
print("RESULT", result)
print("TIME", time.perf_counter() - t0)
print("PEAK", resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
"""


def run_case(name: str, n: int, cap_bytes: int, timeout: float) -> dict:
    body = "\n".join("    " + line for line in CASES[name][2].strip().splitlines())
    code = CHILD.format(cap=cap_bytes, n=n, body=body)
    t0 = time.perf_counter()
    try:
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"case": name, "n": n, "outcome": f"timeout > {timeout:.0f} s", "peak_mib": None,
                "seconds": timeout}
    wall = time.perf_counter() - t0
    lines = dict(line.split(" ", 1) for line in proc.stdout.splitlines()
                 if line.startswith(("RESULT", "TIME", "PEAK")))
    if proc.returncode != 0 or "RESULT" not in lines:
        tail = (proc.stderr.strip().splitlines() or ["?"])[-1]
        outcome = f"FAILED: {tail[:70]}"
    else:
        outcome = lines["RESULT"]
    return {"case": name, "n": n, "outcome": outcome,
            "peak_mib": float(lines["PEAK"]) if "PEAK" in lines else None,
            "seconds": float(lines.get("TIME", wall))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scale", type=float, default=1.0, help="multiply every size (default 1 = 10x failing)")
    ap.add_argument("--cap-gib", type=float, default=3.0, help="address-space cap per case (GiB)")
    ap.add_argument("--timeout", type=float, default=600.0, help="seconds per case")
    ap.add_argument("--cases", nargs="*", default=list(CASES), choices=list(CASES))
    ap.add_argument("--json", help="also write the rows to this file")
    args = ap.parse_args()
    rows = []
    print(f"| case | n | failed before | outcome | peak MiB | time s |  (cap {args.cap_gib:g} GiB)")
    print("|---|---|---|---|---|---|")
    for name in args.cases:
        n = max(1, int(round(CASES[name][0] * args.scale)))
        row = run_case(name, n, int(args.cap_gib * 2**30), args.timeout)
        rows.append(row)
        peak = "-" if row["peak_mib"] is None else f"{row['peak_mib']:.0f}"
        print(f"| {name} | {n:,} | {CASES[name][1]} | {row['outcome']} | {peak} | {row['seconds']:.1f} |",
              flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
