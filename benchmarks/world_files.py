"""World files: JSON against the binary ``.npz`` format of ``WorldModel.save``/``load``.

Builds ``wg.scenes.campus_site(buildings=4, n_objects=N)`` worlds, saves each in the formats and
loads it again in a fresh child process (so the built world's memory does not slow the load),
``--repeat`` times, printing the median.  JSON is measured at ``--json-objects`` only: at 1M
objects it takes minutes (8.8 s to load 50k, measured once).  The row "npz, no link tables"
is the binary file without its stored link tables: the load then searches and sorts the links
itself, which is where the time of a load went before they were stored.

    python benchmarks/world_files.py                          # 1M objects npz, 50k JSON
    python benchmarks/world_files.py --objects 200000 --json-objects 20000

Measured (``--repeat 5``, 2 cores; the load times of this shared machine vary by about +-1 s
between runs: the 1M npz load was 1.40 s in this run, 2.95 s in an earlier one)::

    | format | objects | links | build s | save s | load s | MB |
    |---|---:|---:|---:|---:|---:|---:|
    | json | 50,000 | 1,370,868 | 1.0 | 2.11 | 3.59 | 18 |
    | npz | 50,000 | 1,370,868 | 1.0 | 0.02 | 0.11 | 36 |
    | npz, no link tables | 50,000 | 1,370,868 | 1.0 | - | 0.58 | 3 |
    | npz | 1,000,000 | 27,792,953 | 22.5 | 0.43 | 1.40 | 727 |
    | npz, no link tables | 1,000,000 | 27,792,953 | 22.5 | - | 20.01 | 60 |
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import worldgraph as wg

CHILD = """
import sys, time
import worldgraph as wg
t = time.perf_counter()
world = wg.WorldModel.load(sys.argv[1])
print(time.perf_counter() - t, len(world))
"""


def load_seconds(path: str, n: int, repeat: int) -> float:
    """Median time of ``WorldModel.load(path)`` over ``repeat`` fresh child processes."""
    times = []
    for _ in range(repeat):
        out = subprocess.run([sys.executable, "-c", CHILD, path], check=True, capture_output=True, text=True,
                             env=dict(os.environ))
        seconds, count = out.stdout.split()
        assert int(count) == n, (count, n)
        times.append(float(seconds))
    return statistics.median(times)


def strip_links(src: str, dst: str) -> None:
    """``src`` without its link-table entries."""
    with np.load(src, allow_pickle=False) as data:
        entries = {k: data[k] for k in data.files if k not in ("link_i", "link_j", "link_length")}
    with open(dst, "wb") as fh:
        np.savez(fh, **entries)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--objects", type=int, default=1_000_000, help="objects of the binary-file world")
    parser.add_argument("--json-objects", type=int, default=50_000, help="objects of the world saved in both")
    parser.add_argument("--repeat", type=int, default=3, help="loads per file (median printed)")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for n, formats in ((args.json_objects, ("json", "npz")), (args.objects, ("npz",))):
            t = time.perf_counter()
            world = wg.scenes.campus_site(buildings=4, n_objects=n).world
            build = time.perf_counter() - t
            links = len(world._links._length)
            for fmt in formats:
                path = os.path.join(folder, f"w{n}.{fmt}")
                t = time.perf_counter()
                world.save(path)
                save = time.perf_counter() - t
                rows.append((fmt, n, links, build, save, os.path.getsize(path) / 1e6, path))
            del world
            bare = os.path.join(folder, f"w{n}_bare.npz")
            strip_links(os.path.join(folder, f"w{n}.npz"), bare)
            rows.append(("npz, no link tables", n, links, build, float("nan"), os.path.getsize(bare) / 1e6,
                         bare))
        print(f"campus_site(buildings=4), {os.cpu_count()} cores; load: median of {args.repeat} fresh "
              "processes")
        print("| format | objects | links | build s | save s | load s | MB |")
        print("|---|---:|---:|---:|---:|---:|---:|")
        for fmt, n, links, build, save, mb, path in rows:
            load = load_seconds(path, n, args.repeat)
            save_text = "-" if save != save else f"{save:.2f}"
            print(f"| {fmt} | {n:,} | {links:,} | {build:.1f} | {save_text} | {load:.2f} | {mb:.0f} |",
                  flush=True)


if __name__ == "__main__":
    main()
