"""Benchmark: rendering time of perception.mujoco scans of the Franka kitchen, per view.

Builds :class:`perception.mujoco.MujocoScene` on the gymnasium-robotics Franka kitchen (typed
by :data:`worldgraph.importers.franka.FRANKA_BODY_TYPES`: doors, knobs, burners, the light
switch, the kettle), runs one
warm-up scan per image size (the first renderer of a size creates its OpenGL context), then
``--repeats`` scans of ``--views`` views from a robot pose facing the stove, and prints per
image size and sensor the median seconds per view of each stage (``render``: RGB, depth and
segmentation, both cameras for stereo, with the depth noise; ``detect``; ``percepts``: the
front end) and the number of percepts.  Nothing is asserted.

Run:  MUJOCO_GL=egl python benchmarks/mujoco_scan.py [--sizes 640x480 160x120] [--views 20]
      [--repeats 3]   (with ``PYTHONPATH=.`` from a worktree)
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402

import worldgraph as wg  # noqa: E402
from perception.mujoco import MujocoScene  # noqa: E402
from worldgraph.importers.franka import FRANKA_BODY_TYPES  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", default=["640x480", "160x120"])
    parser.add_argument("--views", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    scene = MujocoScene(wg.franka_kitchen_path() / "kitchen_env_model.xml", type_of=FRANKA_BODY_TYPES)
    pose = np.eye(4)
    pose[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]  # ego x along world +y: facing the stove
    pose[:3, 3] = [-0.3, -1.2, 1.7]
    print(f"{'size':>9} {'sensor':>6} {'render ms/view':>15} {'detect':>7} {'percepts':>9} {'n':>4}")
    for text in args.sizes:
        size = tuple(int(x) for x in text.split("x"))
        for sensor in ("rgbd", "stereo"):
            scene.scan(pose, sensor, 2, rng=np.random.default_rng(0), image_size=size)  # warm-up
            rows = []
            for r in range(args.repeats):
                scan = scene.scan(pose, sensor, args.views, rng=np.random.default_rng(r), image_size=size)
                t = scan.timings
                rows.append((t.render / t.n_views, t.detect / t.n_views, t.percepts / t.n_views,
                             len(scan.percepts)))
            med = np.median(np.array(rows), axis=0)
            print(f"{text:>9} {sensor:>6} {1000 * med[0]:15.0f} {1000 * med[1]:7.1f} {1000 * med[2]:9.1f} "
                  f"{int(med[3]):4d}")


if __name__ == "__main__":
    main()
