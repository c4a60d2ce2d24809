"""
From pixels to pose: rendered stereo images -> detections -> percepts -> localisation
=====================================================================================

Run it from the repository root::

    python examples/04_from_images.py [--seed 0] [--views 9] [--out out]

A 6 m wide hall with doors and door handles along both walls (the building-floor case of the
paper) is rendered as coloured boxes by the stereo head of a robot standing in it, at every
head pose of a neck-yaw scan (lit from the camera's side, as the classifier's training
scenes are).  In each stereo pair the doors and handles are found by colour segmentation,
region eigen-features and a Gaussian classifier trained on rendered samples, matched along
epipolar lines and triangulated (OpenCV); the percepts are mapped to the ego frame through
the head's kinematic chain, fused by mean shift, and localised in the corridor's world model.
Saves the stereo pair with the most percepts and a top view (``04_from_images.png``).
"""

from __future__ import annotations

import time

import numpy as np
from _common import parse_args_with, pyplot

import perception as pc
import worldgraph as wg

RECOGNISED = ("door", "handle")


def hall_boxes(world: wg.WorldModel) -> list[pc.Box]:
    """Boxes of the recognisable objects at their world poses (default per-type sizes and
    colours: the rendered handle is a 3 cm bar, thick enough to be seen at 5 m)."""
    idx = np.flatnonzero(np.isin(world.types, RECOGNISED))
    objects = [world.objects[i] for i in idx]
    return pc.scene_boxes([o.type for o in objects], [o.position for o in objects],
                          rotations=[o.pose[:3, :3] for o in objects])


def robot_pose(world: wg.WorldModel, rng: np.random.Generator) -> np.ndarray:
    """``world_from_ego`` in the hall: near its centre line, head base at 1.6 m, looking
    roughly along the hall (the scan sweeps the head across both walls)."""
    lower, upper = world.bounds
    x = rng.uniform(lower[0] + 4.0, upper[0] - 4.0)
    yaw = rng.choice([0.0, np.pi]) + rng.uniform(-0.3, 0.3)
    c, s = np.cos(yaw), np.sin(yaw)
    pose = np.eye(4)
    pose[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    pose[:3, 3] = [x, rng.uniform(-0.5, 0.5), 1.6]
    return pose


#: The training scenes' light, in the left camera frame (from behind the camera and above).
LIGHT_IN_CAMERA = np.array([0.25, -0.55, -0.8])


def main() -> None:
    args = parse_args_with(__doc__, [
        ("--views", {"type": int, "default": 9, "help": "head poses in the scan"}),
    ])
    rng = np.random.default_rng(args.seed)
    world = wg.WorldModel.from_trimesh(wg.scenes.corridor_scene(n_doors=16, seed=args.seed, width=6.0))
    boxes = hall_boxes(world)
    truth = robot_pose(world, rng)
    rig = pc.StereoRig.default(baseline=0.093)
    head = pc.default_head(baseline=0.093)

    t = time.perf_counter()
    classifier = pc.train_classifier(rig, rng, n_scenes=8 if args.smoke else 30)
    print(f"classifier trained on rendered samples in {time.perf_counter() - t:.1f} s")

    n_views = 3 if args.smoke else args.views
    yaws = np.radians(np.linspace(-80.0, 80.0, n_views))
    percepts: list[pc.Percept] = []
    shown = None
    t_render = t_recognise = 0.0
    for k, yaw in enumerate(yaws):
        angles = dict.fromkeys(head.names, 0.0)
        angles["neck_yaw"] = float(yaw)
        angles["neck_pitch"] = 0.15  # a little downwards
        ego_from_camera = head.ego_from_camera(angles)
        world_from_camera = truth @ ego_from_camera
        t = time.perf_counter()
        left, right = pc.render_stereo(rig, np.linalg.inv(world_from_camera), boxes, rng,
                                       light_direction=world_from_camera[:3, :3] @ LIGHT_IN_CAMERA)
        t_render += time.perf_counter() - t
        t = time.perf_counter()
        found = pc.recognize(rig, left, right, classifier, ego_from_camera=ego_from_camera)
        t_recognise += time.perf_counter() - t
        percepts += found
        if shown is None or len(found) > len(shown[2]):
            shown = (left, right, found, k)
    fused = pc.fuse_percepts(percepts, bandwidth={"door": 0.3, "handle": 0.1}, min_views=1)
    print(f"{n_views} stereo pairs: render {1e3 * t_render / n_views:.0f} ms, detect + match + "
          f"triangulate {1e3 * t_recognise / n_views:.0f} ms per pair; {len(percepts)} percepts "
          f"fused into {len(fused)} ({sum(p.type == 'handle' for p in fused)} handles)")

    res = wg.localize(world, fused, method="ml")
    if np.all(np.isfinite(res.position)):
        err = np.linalg.norm(res.position - truth[:3, 3])
        cos = (np.trace(res.transformation[:3, :3].T @ truth[:3, :3]) - 1.0) / 2.0
        rot = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
        # the bound is only as good as the percept covariances (recognize: centroid noise plus
        # the offset between a region's centroid and the object's centre); e^T C^-1 e ~ chi^2_3
        e = res.position - truth[:3, 3]
        nees = float(e @ np.linalg.solve(res.covariance, e))
        print(f"pose: status {res.status}, {len(res.correspondences)} matched percepts, position "
              f"error {100 * err:.1f} cm (CRLB sqrt(trace) {100 * np.sqrt(np.trace(res.covariance)):.1f} "
              f"cm, e^T C^-1 e = {nees:.1f}, 3 sigma: 14.2), rotation error {rot:.2f} deg, "
              f"localize {1e3 * res.timings['total']:.1f} ms")
        if res.message:
            print(f"      {res.message}")
    else:
        print(f"no pose: {res.status}: {res.message}")
    save_figure(args, world, truth, fused, res, shown, classifier)


def save_figure(args, world, truth, fused, res, shown, classifier) -> None:
    """The stereo pair with the most percepts, its detections marked by type, above a top view
    of the hall (worldgraph.figures.plots) with the fused percepts placed by the estimate."""
    plt = pyplot()
    fig = plt.figure(figsize=(13, 9), constrained_layout=True)
    grid = fig.add_gridspec(2, 2, height_ratios=[1.0, 1.0])
    left, right, found, k = shown
    colours = wg.figures.plots.type_colours(RECOGNISED)
    for col, (img, title) in enumerate(((left, "left"), (right, "right"))):
        ax = fig.add_subplot(grid[0, col])
        # the detections recognize() matched and triangulated into this view's percepts
        wg.figures.plots.image_view(img, pc.detect(img, classifier), ax=ax, colours=colours,
                            title=f"view {k}, {title} image ({len(found)} percepts from the pair)")
    ax = fig.add_subplot(grid[1, :])
    have_pose = bool(np.all(np.isfinite(res.transformation)))
    wg.figures.plots.top_view(world, percepts=fused, result=res, pose=None if have_pose else truth, ax=ax,
                      types=RECOGNISED, truth=truth,
                      title="hall, top view: fused percepts placed by the "
                            + (f"estimate ({res.status})" if have_pose else "true pose (no estimate)"))
    path = args.out / "04_from_images.png"
    fig.savefig(path, dpi=75, bbox_inches="tight")
    print(f"saved {path}")


if __name__ == "__main__":
    main()
