"""Time the perception layer and measure the depth-error model on real pixels.

    python benchmarks/stereo_depth.py [--repeat 7]

Prints Markdown tables: (a) mean-shift fusion of 200 raw percepts, (b) the SGBM depth-error
table of the Middlebury motorcycle pair with the fitted depth factor of eq. 6, (c)
``StereoRig.triangulate`` for 1000 points, and (d) the image pipeline per 640x480 stereo pair
(added by ``image_pipeline_rows`` once ``perception.recognition`` exists).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import perception as pc  # noqa: E402
from perception import MissingExtraError  # noqa: E402
from perception.middlebury import BASELINE_M, FOCAL_PX, depth_error_table  # noqa: E402


def median_time(fn: Callable[[], object], repeat: int) -> float:
    fn()  # warm-up
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def scan_percepts(n: int, seed: int = 0) -> list[pc.Percept]:
    """Exactly ``n`` raw percepts of a seeded 12-object scan (20 views, 2% false)."""
    rng = np.random.default_rng(seed)
    types = [["handle", "door", "knob"][i % 3] for i in range(12)]
    out: list[pc.Percept] = []
    while len(out) < n:
        X = np.column_stack([rng.uniform(1, 4.5, 12), rng.uniform(-3, 3, 12), rng.uniform(-0.4, 1.0, 12)])
        out += pc.simulate_scan(types, X, np.eye(4), rng, n_views=20, false_rate=0.02)
    return out[:n]


def fusion_rows(repeat: int) -> list[str]:
    rows = []
    for n in (200,):
        percepts = scan_percepts(n)
        t = median_time(lambda p=percepts: pc.fuse_percepts(p), repeat)
        k = len(pc.fuse_percepts(percepts))
        rows.append(f"| fuse_percepts, {n} raw percepts -> {k} fused | {1e3 * t:.2f} ms |")
    return rows


def triangulation_rows(repeat: int) -> list[str]:
    rng = np.random.default_rng(1)
    z = rng.uniform(0.5, 6.0, 1000)
    X = np.column_stack([rng.uniform(-0.4, 0.4, 1000) * z, rng.uniform(-0.3, 0.3, 1000) * z, z])
    base = pc.StereoRig.default()
    R, _ = cv2.Rodrigues(np.array([0.01, -0.02, 0.005]))
    distorted = pc.StereoRig.from_opencv(
        base.K1,
        [-0.2, 0.05, 0.001, -0.001, 0.01],
        base.K2,
        [-0.18, 0.04, 0, 0, 0],
        R,
        [-0.093, 0.001, 0],
        (640, 480),
    )
    rows = []
    for name, rig in (("no distortion", base), ("5-coefficient distortion", distorted)):
        uv1, uv2 = rig.project(X)
        t = median_time(lambda r=rig, a=uv1, b=uv2: r.triangulate(a, b), repeat)
        rows.append(f"| triangulate 1000 points, {name} | {1e3 * t:.2f} ms |")
        t = median_time(lambda r=rig, a=uv1, b=uv2: pc.triangulation_covariance(r, a, b), repeat)
        rows.append(f"| triangulation_covariance 1000 points, {name} | {1e3 * t:.2f} ms |")
    return rows


IMAGE_SCENES = 100  # seeded scenes of the image-pipeline rows


def image_pipeline_rows(repeat: int) -> list[str]:
    """Image-pipeline time per 640x480 stereo pair (left to the recognition engineer).

    Returns ``[]`` while ``perception.recognition`` does not exist; otherwise rows
    ``| what | time |`` for the table printed by :func:`main`.
    """
    try:
        from perception import recognition as rc
    except ImportError:
        return []
    # Image pipeline (recognition engineer): classifier trained on 30 rendered scenes, then
    # IMAGE_SCENES new seeded scenes (1-3 doors with handles at 2.5-5 m, 0-2 clutter boxes).
    # Times are medians over the scenes (``repeat`` is not used: every scene is a new pair).
    # Visible handle: centre inside both images on a pixel of the handle, >= 20 px in each;
    # a handle percept is false when no unclaimed true handle lies within 3 sigma of it.
    rig = pc.StereoRig.default(image_size=(640, 480))
    rng = np.random.default_rng(0)
    t0 = time.perf_counter()
    classifier = rc.train_classifier(rig, rng, n_scenes=30)
    train_time = time.perf_counter() - t0
    render_t, detect_t, pipeline_t = [], [], []
    n_visible = n_found = n_percepts = n_false = 0
    err_sigma = []
    for _ in range(IMAGE_SCENES):
        boxes, pose = rc.random_scene(rng)
        t0 = time.perf_counter()
        left, right = rc.render_stereo(rig, pose, boxes, rng)
        render_t.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        rc.detect(left, classifier)
        detect_t.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        percepts = rc.recognize(rig, left, right, classifier)
        pipeline_t.append(time.perf_counter() - t0)
        visible = rc.visible_mask(rig, pose, boxes)
        idx = np.array([i for i, b in enumerate(boxes) if b.type == "handle"], dtype=int)
        truth = np.array([boxes[i].center for i in idx]).reshape(-1, 3) @ pose[:3, :3].T + pose[:3, 3]
        claimed: set[int] = set()
        for p in percepts:
            if p.type != "handle":
                continue
            n_percepts += 1
            dist = np.linalg.norm(truth - p.position, axis=1) if len(truth) else np.array([np.inf])
            k = int(np.argmin(dist))
            if dist[k] <= 3 * p.sigma and k not in claimed:
                claimed.add(k)
                err_sigma.append(dist[k] / p.sigma)
            else:
                n_false += 1
        n_visible += int(visible[idx].sum())
        n_found += sum(1 for k in claimed if visible[idx[k]])
    ms = 1e3
    n = IMAGE_SCENES
    return [
        f"| classifier training: render + segment 30 scenes, fit | {train_time:.2f} s |",
        f"| render one 640x480 stereo pair (median of {n} scenes) | {ms * np.median(render_t):.1f} ms |",
        f"| detect in one 640x480 image (median of {n}) | {ms * np.median(detect_t):.1f} ms |",
        f"| detect + match + triangulate per stereo pair (median of {n}) | "
        f"{ms * np.median(pipeline_t):.1f} ms |",
        f"| detect + match + triangulate per stereo pair (95th percentile) | "
        f"{ms * np.percentile(pipeline_t, 95):.1f} ms |",
        f"| visible handles found ({n} seeded scenes) | {n_found}/{n_visible} = "
        f"{n_found / max(n_visible, 1):.1%} |",
        f"| false handle percepts | {n_false}/{n_percepts} = {n_false / max(n_percepts, 1):.1%} |",
        f"| handle error / sigma, median | {np.median(err_sigma) if err_sigma else float('nan'):.2f} |",
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()

    print("## Perception timings (median of", args.repeat, "runs)\n")
    print("| what | time |")
    print("|---|---|")
    for row in fusion_rows(args.repeat) + triangulation_rows(args.repeat) + image_pipeline_rows(args.repeat):
        print(row)

    print("\n## SGBM depth error on the Middlebury motorcycle pair (skimage.data.stereo_motorcycle)\n")
    try:
        t0 = time.perf_counter()
        table = depth_error_table()
        elapsed = time.perf_counter() - t0
    except MissingExtraError as exc:
        print(f"(not available: {exc})")
        return
    print(table.to_markdown())
    fb = FOCAL_PX * BASELINE_M
    print()
    print("| quantity | value |")
    print("|---|---|")
    print(f"| fitted depth_factor (sigma = Z^2 / depth_factor) | {table.depth_factor:.0f} 1/m |")
    print(f"| disparity error median / robust std | {table.disparity_error_median:+.3f} / "
          f"{table.disparity_error_std:.3f} px |")  # fmt: skip
    print(f"| depth_factor predicted by f b / sigma_d | {fb / table.disparity_error_std:.0f} 1/m |")
    print(f"| compared pixels (valid fraction) | {table.n_pixels} ({table.valid_fraction:.2f}) |")
    print(f"| SGBM + table time | {1e3 * elapsed:.0f} ms |")


if __name__ == "__main__":
    main()
