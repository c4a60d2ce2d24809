"""
Localise a robot in the embedded kitchen: scan, fuse, associate, estimate the 6D pose
=====================================================================================

Run it from the repository root::

    python examples/03_localize_kitchen.py [--seed 0] [--depth-factor 1000] [--out out]
                                           [--rerun out/kitchen.rrd]

The main job.  Builds the paper-sized procedural kitchen (753 typed objects, ~13.8k
vertices), puts the robot at a random pose, simulates a 20-view stereo-head scan of the
recognisable objects (doors, handles, drawers, knobs; sigma = rho^2 / depth_factor, missed
detections and false percepts), fuses the raw percepts by mean shift, associates them with
the world model and estimates the pose twice: with the paper's pipeline (``method="paper"``:
proximity and orientation filtering, radial projection and the meet) and with the default
maximum-likelihood estimator (``method="ml"``: consistency-graph cliques, ML position).
Prints the pose errors against the Cramer-Rao bound, the time of each stage beside the times
the paper reports, and saves a top view (``03_localize_kitchen.png``).  With ``--rerun FILE`` it
also writes the world, the percepts, the ML estimate with its 3-sigma ellipsoid and the true pose
to a rerun recording (``rerun`` extra; open it with ``rerun FILE``; no viewer is started here).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from _common import parse_args_with, pyplot

import perception as pc
import radialopt as ro
import worldgraph as wg

RECOGNISED = ("door", "handle", "drawer", "knob")
#: Stage times the paper reports (ARMAR-III, 2010 hardware), milliseconds.
PAPER_MS = {"association": "100-150 (pruning)", "position": "200-500 (hypotheses)",
            "vertex enumeration": "15-50"}


def robot_pose(world: wg.WorldModel, rng: np.random.Generator) -> np.ndarray:
    """``world_from_ego``: head height 1.6 m, free floor space in the middle of the room,
    any heading."""
    lower, upper = world.bounds
    xy = rng.uniform(lower[:2] + 2.0, upper[:2] - 2.0)
    yaw = rng.uniform(-np.pi, np.pi)
    c, s = np.cos(yaw), np.sin(yaw)
    pose = np.eye(4)
    pose[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    pose[:3, 3] = [xy[0], xy[1], 1.6]
    return pose


def type_bandwidths(world: wg.WorldModel, raw: list[pc.Percept], scale: float = 0.5,
                    n_sigma: float = 3.0) -> dict[str, np.ndarray]:
    """Mean-shift bandwidth per recognised type: the covariance of the class model's vertices
    (the paper's choice) scaled by ``scale**2``, widened by the percepts' own noise
    (``n_sigma`` times the median sigma of that type's raw percepts), so that the views of one
    object fall inside one kernel even where the class geometry is small (handles, knobs)."""
    out = {}
    for t in RECOGNISED:
        first = world.objects[int(world.indices_of(t)[0])]
        sig = [p.sigma for p in raw if p.type == t]
        noise = n_sigma * float(np.median(sig)) if sig else 0.0
        out[t] = scale**2 * pc.class_bandwidth(world.class_vertices[first.geometry]) + noise**2 * np.eye(3)
    return out


def rotation_error_deg(a: np.ndarray, b: np.ndarray) -> float:
    cos = (np.trace(a[:3, :3].T @ b[:3, :3]) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))


def report(name: str, res: wg.LocalizationResult, truth: np.ndarray) -> None:
    if not np.all(np.isfinite(res.position)):
        print(f"{name:>5}: no pose ({res.status}: {res.message})")
        return
    err = np.linalg.norm(res.position - truth[:3, 3])
    bound = np.sqrt(np.trace(res.covariance))
    print(f"{name:>5}: status {res.status}, {len(res.correspondences)} matched percepts, "
          f"position error {100 * err:.1f} cm (CRLB sqrt(trace) {100 * bound:.1f} cm), "
          f"rotation error {rotation_error_deg(res.transformation, truth):.2f} deg")
    if res.message:
        print(f"       {res.message}")


def main() -> None:
    args = parse_args_with(__doc__, [
        ("--depth-factor", {"type": float, "default": 1000.0, "help": "eq. 6 (1/m)"}),
        ("--views", {"type": int, "default": 20, "help": "head poses in the scan"}),
        ("--rerun", {"type": Path, "default": None, "metavar": "FILE.rrd",
                     "help": "also write a rerun recording (pip install gaussian-spheres[rerun])"}),
    ])
    rng = np.random.default_rng(args.seed)
    timings: dict[str, float] = {}

    t = time.perf_counter()
    world = wg.scenes.kitchen(seed=0)
    timings["build kitchen"] = time.perf_counter() - t
    t = time.perf_counter()
    world.graph  # noqa: B018 - the networkx world graph, built once per world (the paper's filters view it)
    timings["networkx world graph (once per world)"] = time.perf_counter() - t
    truth = robot_pose(world, rng)
    seen = np.flatnonzero(np.isin(world.types, RECOGNISED))

    t = time.perf_counter()
    raw = pc.simulate_scan(world.types[seen].tolist(), world.positions[seen], truth, rng,
                           n_views=6 if args.smoke else args.views, depth_factor=args.depth_factor)
    timings["scan (simulated)"] = time.perf_counter() - t
    t = time.perf_counter()
    fused = pc.fuse_percepts(raw, bandwidth=type_bandwidths(world, raw))
    timings["fusion"] = time.perf_counter() - t
    print(f"kitchen: {len(world)} objects; robot at {truth[:3, 3].round(2)}; "
          f"{len(raw)} raw percepts in {args.views} views fused into {len(fused)}")

    results = {}
    for method in ("paper", "ml"):
        results[method] = wg.localize(world, fused, method=method)
        report(method, results[method], truth)
    best = results["ml"]

    # the paper's vertex enumeration, on the restriction polytope of the matched spheres
    vertex_ms = float("nan")
    if len(best.correspondences) >= 3:
        pairs = best.correspondences[:6]
        spheres = ro.make_spheres(world.positions[[o for _, o in pairs]],
                                  [fused[p].range for p, _ in pairs], [fused[p].sigma for p, _ in pairs])
        t = time.perf_counter()
        ro.enumerate_vertices(ro.RestrictionPolytope.from_spheres(spheres))
        vertex_ms = 1e3 * (time.perf_counter() - t)

    print("\n| stage | paper (ms) | ml (ms) | paper's reported (ms) |")
    print("|---|---|---|---|")
    for stage in ("association", "position", "orientation", "total"):
        row = [f"{1e3 * results[m].timings.get(stage, float('nan')):.1f}" for m in ("paper", "ml")]
        print(f"| {stage} | {row[0]} | {row[1]} | {PAPER_MS.get(stage, '-')} |")
    print(f"| vertex enumeration ({min(len(best.correspondences), 6)} spheres) | - | {vertex_ms:.1f} | "
          f"{PAPER_MS['vertex enumeration']} |")
    for stage, sec in timings.items():
        print(f"| {stage} | - | {1e3 * sec:.0f} | - |")

    save_figure(args, world, seen, fused, results, truth)
    if args.rerun is not None:
        save_recording(args.rerun, world, fused, best, truth)


def save_recording(path: Path, world: wg.WorldModel, fused: list, est: wg.LocalizationResult,
                   truth: np.ndarray) -> None:
    """The world, the fused percepts placed by the ML estimate, the estimate with its 3-sigma
    ellipsoid and the true pose as a rerun recording file (worldgraph.figures.rerun_log)."""
    try:
        import rerun as rr
    except ImportError:
        raise SystemExit("--rerun needs rerun-sdk: pip install gaussian-spheres[rerun]") from None
    path.parent.mkdir(parents=True, exist_ok=True)
    rec = rr.RecordingStream("gaussian_spheres_kitchen")
    rec.save(str(path))
    entities = wg.figures.rerun_log.log_rerun(world, fused, est, recording=rec, truth=truth)
    rec.flush()
    rec.disconnect()
    print(f"saved {path} ({len(entities)} entities; view it with: rerun {path})")


def save_figure(args, world: wg.WorldModel, seen: np.ndarray, fused: list, results: dict,
                truth: np.ndarray) -> None:
    """Top view of the kitchen with the fused percepts placed by the ML estimate, its 3-sigma
    ellipse and near-best alternatives (worldgraph.figures.plots), the paper method's estimate and the
    true pose."""
    plt = pyplot()
    fig, (ax, zoom) = plt.subplots(1, 2, figsize=(15, 7.5), width_ratios=[2.2, 1],
                                   constrained_layout=True)
    est = results["ml"]
    paper = results["paper"]
    for a in (ax, zoom):
        wg.figures.plots.top_view(world, percepts=fused, result=est, ax=a, types=RECOGNISED, truth=truth,
                          legend=False)
        if np.all(np.isfinite(paper.position)):
            a.plot(*paper.position[:2], "s", mfc="none", mec="tab:blue", mew=1.5, ms=12, ls="none",
                   label=f"estimate, paper method ({paper.status})")
    ax.set_title(f"kitchen, top view: fused percepts placed by the ML estimate ({est.status})")
    zoom.set_xlim(truth[0, 3] - 0.25, truth[0, 3] + 0.25)
    zoom.set_ylim(truth[1, 3] - 0.25, truth[1, 3] + 0.25)
    zoom.set_title("0.5 m around the true pose")
    wg.figures.plots.legend_outside(zoom)
    path = args.out / "03_localize_kitchen.png"
    fig.savefig(path, dpi=90, bbox_inches="tight")
    print(f"saved {path}")


if __name__ == "__main__":
    main()
