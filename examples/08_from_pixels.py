"""
From pixels to the pose: a 20-view scan of the Franka kitchen rendered by MuJoCo
================================================================================

Run it from the repository root (needs the ``mujoco`` extra and the Franka kitchen's files;
headless machines render with ``MUJOCO_GL=egl``, which this script sets when unset)::

    pip install -e ".[mujoco,examples]" && pip install --no-deps gymnasium-robotics
    python examples/08_from_pixels.py [--sensor rgbd|stereo] [--seed 0] [--out out]

The paper's experiment from pixels, in a kitchen nobody on the team wrote: the Franka kitchen
of gymnasium-robotics (its MJCF file) is the map (``WorldModel.from_file``) and the scene a
MuJoCo head scans (:class:`perception.mujoco.MujocoScene`): 20 views of the default head's
sweep, each rendered (RGB, depth, segmentation), every typed body in view detected from the
segmentation (its instance mask), the detections turned into percepts by the depth front end
(:func:`perception.rgbd_percepts`) or the stereo one (:func:`perception.stereo_percepts`),
fused (:func:`perception.fuse_percepts`) and localised (:func:`worldgraph.localize`, ML and the
paper's pipeline).  Prints the pose errors and each stage's time beside the paper's, and saves
one rendered view with its detections above the top view (``08_from_pixels.png``).
"""

from __future__ import annotations

import os
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402
from _common import parse_args_with, pyplot  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

import perception as pc  # noqa: E402
import worldgraph as wg  # noqa: E402
from perception.mujoco import MujocoScene  # noqa: E402
from worldgraph.importers.franka import FRANKA_BODY_TYPES, franka_kitchen_path  # noqa: E402

#: Stage times the paper reports (ARMAR-III, 2010 hardware).
PAPER = {"render": "15-20 s (20 stereo images, scanning)", "localize": "100-150 ms pruning + 200-500 ms "
         "hypotheses"}


def robot_pose(rng: np.random.Generator) -> np.ndarray:
    """``world_from_ego``: standing 1.1-1.7 m in front of the counter, head at 1.5-1.7 m, facing it
    (``MujocoScene.robot_poses`` draws poses anywhere in free space, as the benchmark does)."""
    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_euler("z", np.radians(90.0 + rng.uniform(-10.0, 10.0))).as_matrix()
    pose[:3, 3] = [rng.uniform(-0.7, 0.3), rng.uniform(-1.7, -1.1), rng.uniform(1.5, 1.7)]
    return pose


def errors(result: wg.LocalizationResult, truth: np.ndarray) -> tuple[float, float]:
    if not np.all(np.isfinite(result.transformation)):
        return float("nan"), float("nan")
    dpos = float(np.linalg.norm(result.transformation[:3, 3] - truth[:3, 3]))
    rot = Rotation.from_matrix(truth[:3, :3] @ result.transformation[:3, :3].T)
    return dpos, float(np.degrees(rot.magnitude()))


def main() -> None:
    args = parse_args_with(__doc__, [("--sensor", {"choices": ["rgbd", "stereo"], "default": "rgbd"})])
    rng = np.random.default_rng(args.seed)
    path = franka_kitchen_path() / "kitchen_env_model.xml"
    n_views, size = (12, (320, 240)) if args.smoke else (20, (640, 480))

    t0 = time.perf_counter()
    world = wg.WorldModel.from_file(path, type_of=FRANKA_BODY_TYPES)
    scene = MujocoScene(path, type_of=FRANKA_BODY_TYPES)
    t_load = time.perf_counter() - t0
    counts = {str(t): int(n) for t, n in zip(*np.unique(world.types, return_counts=True), strict=True)}
    print(f"map: {len(world)} typed objects {counts}")

    truth = robot_pose(rng)
    scan = scene.scan(truth, sensor=args.sensor, n_views=n_views, rng=rng, image_size=size,
                      pitch_deg=(-20.0, 0.0))  # half the views look up at the wall cabinets
    t0 = time.perf_counter()
    fused = pc.fuse_percepts(list(scan.percepts), bandwidth=pc.percept_bandwidths(scan.percepts))
    t_fuse = time.perf_counter() - t0
    dropped = [d.reason for view in scan.dropped for d in view]
    reasons = {str(r): int(n) for r, n in zip(*np.unique(dropped, return_counts=True), strict=True)}
    print(f"{args.sensor} scan: {len(scan.views)} views of {size[0]}x{size[1]}, "
          f"{sum(len(v.detections) for v in scan.views)} detections, {len(scan.percepts)} percepts "
          f"({len(dropped)} dropped: {reasons}) fused into "
          f"{len(fused)}")

    t0 = time.perf_counter()
    ml = wg.localize(world, fused)
    t_ml = time.perf_counter() - t0
    t0 = time.perf_counter()
    paper = wg.localize(world, fused, method="paper")
    t_paper = time.perf_counter() - t0
    for name, res in (("ml", ml), ("paper", paper)):
        dpos, drot = errors(res, truth)
        print(f"{name:>5}: status {res.status}, {len(res.correspondences)} matched percepts, position error "
              f"{100 * dpos:.1f} cm, rotation error {drot:.2f} deg")
    print(ml.summary())

    rows = [("load map + scene", 1000 * t_load, "-"),
            (f"render ({len(scan.views)} views)", 1000 * scan.timings.render, PAPER["render"]),
            ("detect (segmentation)", 1000 * scan.timings.detect, "-"),
            ("percepts (front end)", 1000 * scan.timings.percepts, "-"),
            ("fusion", 1000 * t_fuse, "-"),
            ("localize (ml)", 1000 * t_ml, PAPER["localize"]),
            ("localize (paper)", 1000 * t_paper, PAPER["localize"])]
    print("\n| stage | ms | paper's reported |\n|---|---|---|")
    for stage, ms, ref in rows:
        print(f"| {stage} | {ms:.0f} | {ref} |")

    plt = pyplot()
    view = max(scan.views, key=lambda v: len(v.detections))
    fig, (ax_img, ax_top) = plt.subplots(1, 2, figsize=(14, 5.5), gridspec_kw={"width_ratios": [1, 1.2]})
    ax_img.imshow(view.rgb)
    colours = {t: plt.cm.tab10(k) for k, t in enumerate(world.type_names)}
    for det in view.detections:
        u0, v0, u1, v1 = det.box
        ax_img.add_patch(plt.Rectangle((u0, v0), u1 - u0, v1 - v0, fill=False, lw=1.5,
                                       color=colours.get(det.type, "k")))
        ax_img.text(u0, v0 - 3, det.type, color=colours.get(det.type, "k"), fontsize=8)
    ax_img.set_title(f"one of {len(scan.views)} rendered views with its detections")
    ax_img.axis("off")
    wg.figures.plots.top_view(world, percepts=fused, result=ml, truth=truth, ax=ax_top,
                      title=f"top view: ML estimate ({ml.status}) and the truth")
    fig.tight_layout()
    out = args.out / "08_from_pixels.png"
    fig.savefig(out, dpi=90)
    print(f"saved {out}")


if __name__ == "__main__":
    main()
