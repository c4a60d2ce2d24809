"""Benchmark: from pixels to the pose in a MuJoCo scene nobody here wrote (default: the Franka kitchen).

For random robot poses in the scene (head 1.2-1.7 m above the floor, level, random yaw, at
least 0.4 m sideways from every typed object, inside the room), a 20-view scan of the default
head (:func:`perception.default_head`, the paper's neck-yaw sweep) is rendered by MuJoCo
(:class:`perception.mujoco.MujocoScene`), every typed body in view detected from the
segmentation (instance masks), turned into percepts by the depth front end
(:func:`perception.rgbd_percepts`) or the stereo one (:func:`perception.stereo_percepts`),
fused (:func:`perception.fuse_percepts`) and localised against ``WorldModel.from_file`` of the
same file (:func:`worldgraph.localize`, every default, and ``method="paper"``).

Verdicts as in ``benchmarks/layouts.py``: unique-correct = status "ok" (not ambiguous), 6D NEES
``e^T C^-1 e <= 20.06`` with ``pose_covariance`` and rotation error <= 2 deg; gross = "ok" and
more than 0.5 m or 10 deg off.  Rows: every pose, and the poses whose scan sees at least 5
typed objects (the issue's target population).

Run:  MUJOCO_GL=egl python benchmarks/from_pixels.py [--scene PATH] [--type-of JSON] [--poses 40]
      [--sensors rgbd stereo] [--views 20] [--size 640x480] [--seed 0] [--max-looks 3] [--any-yaw]

A second table follows the scan alone with ``worldgraph.active_localize`` and
``MujocoScene.look`` (up to ``--max-looks`` looks with the scan's detector model); ``--any-yaw``
turns every pose to a random yaw, so that a first scan may face away from every object.
Prints a Markdown table (progress on stderr).
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import sys
import tempfile
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402
from layouts import CHI2_6_3SIGMA, pose_error, verdict  # noqa: E402 (benchmarks/ on sys.path)

import perception as pc  # noqa: E402
import worldgraph as wg  # noqa: E402
from perception.mujoco import MujocoScene
from worldgraph.importers.franka import FRANKA_BODY_TYPES, franka_kitchen_path
from worldgraph.scenes.mjcf import write_mjcf

MIN_SEEN = 5
STAGES = ("render", "detect", "percepts", "fusion", "localize")


def run(scene: MujocoScene, world: wg.WorldModel, sensor: str, poses: np.ndarray, rng: np.random.Generator,
        views: int, size: tuple[int, int], degrade: dict, max_looks: int) -> dict[str, list]:
    keys = ("verdict", "paper", "nees", "dpos", "drot", "seen", "n", *STAGES, "looked", "looks",
            "looked_nees", "looks_time", "total")
    detector = {k: v for k, v in degrade.items() if k != "pitch_deg"}  # a look's pitch is its direction's
    stats: dict[str, list] = {k: [] for k in keys}
    for k, pose in enumerate(poses):
        t_scan = time.perf_counter()
        scan = scene.scan(pose, sensor=sensor, n_views=views, rng=rng, image_size=size, **degrade)
        t0 = time.perf_counter()
        fused = (pc.fuse_percepts(list(scan.percepts), bandwidth=pc.percept_bandwidths(scan.percepts))
                 if scan.percepts else [])
        t1 = time.perf_counter()
        res = wg.localize(world, fused) if fused else None
        t2 = time.perf_counter()
        paper = wg.localize(world, fused, method="paper") if fused else None
        seen = len({o for v in scan.views for o in v.truth if o >= 0})
        v, nees = verdict(res, pose) if res is not None else ("failed", np.nan)
        stats["verdict"].append(v)
        stats["paper"].append(verdict(paper, pose)[0] if paper is not None else "failed")
        stats["nees"].append(nees)
        if res is not None and res.status == "ok":
            _, dpos, drot = pose_error(res, pose)
            stats["dpos"].append(dpos)
            stats["drot"].append(drot)
        stats["seen"].append(seen)
        stats["n"].append(len(fused))
        stats["render"].append(scan.timings.render_per_view)
        stats["detect"].append(scan.timings.detect)
        stats["percepts"].append(scan.timings.percepts)
        stats["fusion"].append(t1 - t0)
        stats["localize"].append(t2 - t1)
        # look until it knows: explore while there is no pose, plan from the pose while ambiguous
        t3 = time.perf_counter()
        look = functools.partial(scene.look, pose, sensor=sensor, rng=rng, image_size=size, **detector)
        active = wg.active_localize(world, fused, look, max_looks=max_looks)
        t4 = time.perf_counter()
        lv, lnees = verdict(active.result, pose)
        stats["looked"].append(lv)
        stats["looked_nees"].append(lnees)
        stats["looks"].append(active.looks)
        stats["looks_time"].append(t4 - t3)
        # what a robot runs: the scan, fusion and active_localize (which localises the scan itself)
        stats["total"].append((t1 - t_scan) + (t4 - t3))
        print(f"{sensor} {k}: seen {seen}, {len(scan.percepts)} raw -> {len(fused)} fused, {v} "
              f"({res.status if res is not None else 'no percepts'}), NEES {nees:.1f}; after "
              f"{active.looks} looks {lv} ({active.result.status}, {len(active.percepts)} percepts)",
              file=sys.stderr)
    return stats


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", default=None, help="MJCF file (default: the Franka kitchen)")
    ap.add_argument("--type-of", default=None, help="JSON mapping regex -> type (default: FRANKA_BODY_TYPES "
                    "for the Franka kitchen, the default rule for other files)")
    ap.add_argument("--poses", type=int, default=40)
    ap.add_argument("--sensors", nargs="+", default=["rgbd", "stereo"])
    ap.add_argument("--views", type=int, default=20)
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--miss-rate", type=float, default=0.05)
    ap.add_argument("--false-rate", type=float, default=0.02)
    ap.add_argument("--mask-jitter", type=int, default=1, help="mask edge jitter, pixels")
    ap.add_argument("--min-pixels", type=int, default=20)
    ap.add_argument("--max-looks", type=int, default=3, help="looks of active_localize after the scan")
    ap.add_argument("--procedural", type=int, default=0, metavar="N",
                    help="instead of --scene: N procedural kitchens and layouts (worldgraph.scenes) "
                         "exported as textured MJCF (worldgraph.scenes.mjcf), --poses poses each")
    ap.add_argument("--any-yaw", action="store_true",
                    help="turn each robot pose to a random yaw (it need not face an object)")
    ap.add_argument("--pitch", type=float, nargs=2, default=(-20.0, 0.0),
                    help="neck pitch of the sweep's two rows, degrees (negative looks up)")
    args = ap.parse_args()
    width, height = (int(x) for x in args.size.split("x"))
    degrade = dict(miss_rate=args.miss_rate, false_rate=args.false_rate, mask_jitter_px=args.mask_jitter,
                   min_pixels=args.min_pixels, pitch_deg=tuple(args.pitch))
    if args.procedural:
        sources = procedural_scenes(args.procedural, tempfile.mkdtemp(prefix="from_pixels_"))
    else:
        path = args.scene or str(franka_kitchen_path() / "kitchen_env_model.xml")
        if args.type_of:
            type_of = json.loads(args.type_of)
        else:
            type_of = FRANKA_BODY_TYPES if args.scene is None else None
        sources = [(path, type_of)]
    per_sensor: dict[str, list[dict[str, list]]] = {sensor: [] for sensor in args.sensors}
    for k, (path, type_of) in enumerate(sources):
        world = wg.WorldModel.from_file(path, type_of=type_of)
        scene = MujocoScene(path, type_of=type_of)
        print(f"{path}: {len(world)} typed objects {sorted(set(world.types.tolist()))}", file=sys.stderr)
        t0 = time.perf_counter()
        scene.default_centre_offsets()  # measured once per scene, on poses of its own seed
        if "stereo" in args.sensors:  # the outline's errors at the scan's size and jitter, likewise
            scene.default_stereo_offsets((width, height), args.mask_jitter)
        print(f"centre offsets measured in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
        poses = scene.robot_poses(args.poses, np.random.default_rng(args.seed + 10 * k))
        if args.any_yaw:
            yaw_rng = np.random.default_rng(args.seed + 10 * k + 2)
            for pose in poses:
                yaw = yaw_rng.uniform(-np.pi, np.pi)
                pose[:3, :3] = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0],
                                         [0.0, 0.0, 1.0]])
        for sensor in args.sensors:
            per_sensor[sensor].append(run(scene, world, sensor, poses, np.random.default_rng(args.seed + 1),
                                          args.views, (width, height), degrade, args.max_looks))
        scene.close()
    rows = [(sensor, {key: [v for st in runs for v in st[key]] for key in runs[0]})
            for sensor, runs in per_sensor.items()]
    print(table(rows, args.views, (width, height)))
    print()
    print(looks_table(rows, args.max_looks))
    names = ", ".join(os.path.basename(p) for p, _ in sources[:3]) + (" ..." if len(sources) > 3 else "")
    print(f"\n{len(sources)} scene(s) ({names}), poses of MujocoScene.robot_poses "
          f"(seed {args.seed}{', any yaw' if args.any_yaw else ''}); degradation: miss {args.miss_rate}, "
          f"false {args.false_rate}, mask jitter {args.mask_jitter} px, min {args.min_pixels} px.")


def procedural_scenes(n: int, folder: str) -> list[tuple[str, None]]:
    """``n`` procedural scenes written as MJCF files in ``folder``: the paper-sized kitchen and the
    five layout kinds in turn, each with its own seed (layout and materials)."""
    out = []
    for i in range(n):
        kinds = (None, *wg.scenes.LAYOUT_KINDS)
        kind = kinds[i % len(kinds)]
        world = wg.scenes.kitchen(seed=i) if kind is None else wg.scenes.kitchen_layout(kind, seed=i)
        name = f"{kind or 'kitchen'}_{i:02d}.xml"
        out.append((str(write_mjcf(world, os.path.join(folder, name), seed=i)), None))
    return out


def table(rows, views, size) -> str:
    head = ("| sensor | poses (seen >= 5) | fused percepts | unique-correct: all / seen >= 5 | ambiguous "
            "| weak | other | gross ok | paper unique-correct | median error (ok) | mean NEES (ok) "
            "| render per view | detect | percepts | fusion | localize |")
    out = [head, "|" + "---|" * (head.count("|") - 1)]
    for sensor, s in rows:
        v, p = np.array(s["verdict"]), np.array(s["paper"])
        seen = np.array(s["seen"]) >= MIN_SEEN
        every = np.ones(len(v), bool)

        def pct(mask, kind, arr=v):
            return 100.0 * np.mean(arr[mask] == kind) if mask.any() else float("nan")

        ok = np.isin(v, ["correct", "wrong", "gross"])
        nees = np.array(s["nees"])[ok]
        other = 100.0 * np.mean(~np.isin(v, ["correct", "ambiguous", "weak", "wrong", "gross"]))
        dpos = 100 * np.median(s["dpos"]) if s["dpos"] else float("nan")
        drot = np.median(s["drot"]) if s["drot"] else float("nan")
        ms = {k: 1000 * np.median(s[k]) for k in STAGES}
        out.append(
            f"| {sensor} | {len(v)} ({int(seen.sum())}) | {np.mean(s['n']):.1f} | "
            f"{pct(every, 'correct'):.0f} / {pct(seen, 'correct'):.0f} % | {pct(every, 'ambiguous'):.0f} % | "
            f"{pct(every, 'weak'):.0f} % | "
            f"{other:.0f} % | {int(np.sum(v == 'gross'))} | {pct(every, 'correct', p):.0f} % | "
            f"{dpos:.1f} cm, {drot:.2f} deg | {np.mean(nees) if nees.size else float('nan'):.1f} | "
            f"{ms['render']:.0f} ms | {ms['detect']:.0f} ms | {ms['percepts']:.0f} ms | "
            f"{ms['fusion']:.0f} ms | {ms['localize']:.0f} ms |")
    out.append("")
    out.append(f"{views} views of {size[0]}x{size[1]} per scan; medians per scan (rendering per view); "
               f"unique-correct: status ok, not ambiguous, 6D NEES <= {CHI2_6_3SIGMA}, rotation <= 2 deg.")
    return "\n".join(out)


def looks_table(rows, max_looks: int) -> str:
    head = ("| sensor | first scan: share with >= 5 percepts | unique-correct: seen >= 5 / all | "
            f"with <= {max_looks} looks: unique-correct (all) | gross ok | mean NEES (ok) | mean looks "
            "| looks time (median) | scan + looks + localize per pose (median / max) |")
    out = [head, "|" + "---|" * (head.count("|") - 1)]
    for sensor, s in rows:
        v, lv = np.array(s["verdict"]), np.array(s["looked"])
        enough = np.array(s["n"]) >= MIN_SEEN
        first = 100.0 * np.mean(v[enough] == "correct") if enough.any() else float("nan")
        ok = np.isin(lv, ["correct", "wrong", "gross"])
        nees = np.array(s["looked_nees"])[ok]
        out.append(
            f"| {sensor} | {100.0 * np.mean(enough):.0f} % | "
            f"{first:.0f} / {100.0 * np.mean(v == 'correct'):.0f} % | "
            f"{100.0 * np.mean(lv == 'correct'):.0f} % | {int(np.sum(lv == 'gross'))} | "
            f"{np.mean(nees) if nees.size else float('nan'):.1f} | {np.mean(s['looks']):.2f} | "
            f"{np.median(s['looks_time']):.2f} s | "
            f"{np.median(s['total']):.2f} / {np.max(s['total']):.2f} s |")
    out.append("")
    out.append("First scan: fused percepts >= 5 (the target population); with looks: "
               "`active_localize(world, fused, functools.partial(scene.look, pose, ...), "
               "max_looks=...)`, "
               "exploring while there is no pose and planning from it while ambiguous or weak, the "
               "looks with the scan's detector model.")
    return "\n".join(out)


if __name__ == "__main__":
    main()
