"""
Active validation in the kitchen: ambiguous, plan a look, look, unique (paper section 2.3)
==========================================================================================

Run it from the repository root::

    python examples/07_active_validation.py [--seed 0] [--out out]

The robot stands somewhere in the embedded kitchen and recognises 5 objects, one of them a
false percept.  The kitchen's cabinet modules repeat, so ``localize`` says "ambiguous": several
poses explain the 5 percepts about equally well.  ``plan_view`` scores gaze directions by what
each near-best pose predicts would be seen there -- a direction where every pose predicts a
same-type object at the same ego spot tells nothing -- and returns the best direction and the
default head's joint angles that point the left camera at it.  A simulated look (the
recognisable objects within 30 deg of the gaze and 8 m, seen from the true pose, eq.-6 noise)
adds percepts, and ``localize`` runs again on all of them.  The draws of the trial start at
``--seed`` and go on until one is ambiguous.  Saves ``07_active_validation.png``: the
hypotheses with the planned gaze cone under each, the discriminating objects each predicts,
and the outcome.
"""

from __future__ import annotations

import math
import time

import numpy as np
from _common import parse_args, pyplot

import perception as pc
import worldgraph as wg
from worldgraph.active import active_localize

RECOGNISED = ("door", "handle", "drawer", "knob")
HYP_COLOURS = ("tab:red", "tab:orange", "gold", "tab:pink", "tab:cyan", "tab:olive", "tab:gray", "black")
FOV_DEG, MAX_RANGE = 60.0, 8.0


def draw_trial(world: wg.WorldModel, rng: np.random.Generator) -> tuple[np.ndarray, list[pc.Percept]]:
    """A robot pose (head 1.5 m, any yaw) and 4 true + 1 false percepts of recognisable objects."""
    mask = np.isin(world.types, RECOGNISED)
    lo, hi = world.bounds
    while True:
        pose = np.eye(4)
        a = rng.uniform(0, 2 * np.pi)
        pose[:3, :3] = [[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]]
        pose[:2, 3] = rng.uniform(lo[:2] + 0.5, hi[:2] - 0.5)
        pose[2, 3] = 1.5
        seen, truth = pc.simulate_percepts(list(world.types[mask]), world.positions[mask], pose, rng,
                                           max_range=MAX_RANGE, n_false=1, false_types=list(RECOGNISED))
        true_idx = np.flatnonzero(truth >= 0)
        if len(true_idx) >= 4:
            pick = rng.permutation(np.concatenate([rng.choice(true_idx, 4, replace=False),
                                                   np.flatnonzero(truth < 0)]))
            return pose, [seen[i] for i in pick]


def make_look(world: wg.WorldModel, pose: np.ndarray, rng: np.random.Generator):
    """``look(direction)``: what the head recognises within the cone, seen from the true pose."""
    mask = np.isin(world.types, RECOGNISED)
    cos_half = math.cos(math.radians(FOV_DEG / 2))

    def look(direction: np.ndarray) -> list[pc.Percept]:
        seen, _ = pc.simulate_percepts(list(world.types[mask]), world.positions[mask], pose, rng,
                                       max_range=MAX_RANGE)
        return [p for p in seen if p.position @ direction >= cos_half * np.linalg.norm(p.position)]
    return look


def pose_error(res: wg.LocalizationResult, pose: np.ndarray) -> str:
    if not np.all(np.isfinite(res.transformation)):
        return "no pose"
    cos = (np.trace(res.transformation[:3, :3].T @ pose[:3, :3]) - 1) / 2
    rot = math.degrees(math.acos(np.clip(cos, -1, 1)))
    return (f"position error {100 * np.linalg.norm(res.position - pose[:3, 3]):.1f} cm, "
            f"rotation error {rot:.2f} deg")


def wedge(ax, origin: np.ndarray, heading: float, colour: str, label: str | None) -> None:
    """The gaze cone's horizontal section (fov, range) from ``origin`` at ``heading`` (rad)."""
    a = np.linspace(heading - math.radians(FOV_DEG / 2), heading + math.radians(FOV_DEG / 2), 30)
    xs = np.concatenate([[origin[0]], origin[0] + MAX_RANGE * np.cos(a), [origin[0]]])
    ys = np.concatenate([[origin[1]], origin[1] + MAX_RANGE * np.sin(a), [origin[1]]])
    ax.fill(xs, ys, color=colour, alpha=0.12, label=label)
    ax.plot(xs, ys, color=colour, lw=0.8)


def robot(ax, T: np.ndarray, colour: str, label: str, marker: str = "o", arrow: float = 0.6) -> None:
    ax.plot(*T[:2, 3], marker=marker, color=colour, ms=9, ls="none", label=label, mec="k")
    ax.arrow(T[0, 3], T[1, 3], arrow * T[0, 0], arrow * T[1, 0], color=colour, width=arrow / 15,
             length_includes_head=True)


def main() -> None:
    args = parse_args(__doc__)
    t_start = time.perf_counter()
    world = wg.scenes.kitchen(seed=0)
    rng = np.random.default_rng(args.seed)
    draws = 0
    while True:
        draws += 1
        pose, percepts = draw_trial(world, rng)
        first = wg.localize(world, percepts)
        if first.status == "ambiguous" and first.alternatives:
            break
        if draws == 1000:
            raise SystemExit("no ambiguous trial in 1000 draws")
    print(f"draw {draws} from seed {args.seed}: {len(percepts)} percepts (1 false) -> localize says "
          f"{first.status!r} with {1 + len(first.alternatives)} near-best poses")
    head = pc.default_head()
    t0 = time.perf_counter()
    plan = wg.plan_view(world, first, fov_deg=FOV_DEG, max_range=MAX_RANGE, types=RECOGNISED, head=head)
    t_plan = time.perf_counter() - t0
    d = plan.direction
    print(f"plan_view ({1e3 * t_plan:.1f} ms, {plan.candidates} candidate directions): gaze ego direction "
          f"[{d[0]:.2f}, {d[1]:.2f}, {d[2]:.2f}], azimuth {math.degrees(math.atan2(d[1], d[0])):.0f} deg, "
          f"elevation {math.degrees(math.asin(d[2])):.0f} deg; P(the look tells the poses apart) >= "
          f"{plan.score:.3f}")
    for h, (w, exp, disc) in enumerate(zip(plan.weights, plan.expected, plan.discriminating, strict=True)):
        T = plan.hypotheses[h]
        off = np.linalg.norm(T[:3, 3] - pose[:3, 3])
        print(f"  hypothesis {h} ({off:.2f} m from the truth): weight {w:.2f}, {len(exp)} objects expected "
              f"in view, {int(disc.sum())} of them absent at that ego spot under some other hypothesis")
    names = ", ".join(f"{n} {math.degrees(q):.1f}"
                      for n, q in zip(head.names, plan.joint_angles, strict=True))
    print(f"default head joint angles (deg): {names}; optical axis off the target by "
          f"{math.degrees(plan.pointing_error):.3f} deg")

    out = active_localize(world, percepts, make_look(world, pose, rng), types=RECOGNISED, head=head)
    for k, res in enumerate(out.results):
        print(f"after {k} look(s): {res.status}, {len(res.correspondences)} matched, {pose_error(res, pose)}")
    print(f"{len(out.percepts) - len(percepts)} new percepts from {out.looks} look(s)")

    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(14, 6.6), sharex=True, sharey=True)
    ax = axes[0]
    wg.figures.plots.top_view(world, ax=ax, types=RECOGNISED, legend=False)
    for h, T in enumerate(plan.hypotheses):
        c = HYP_COLOURS[h % len(HYP_COLOURS)]
        heading = math.atan2(*(T[:3, :3] @ d)[1::-1])
        wedge(ax, T[:3, 3], heading, c, None)
        robot(ax, T, c, f"hypothesis {h} (w {plan.weights[h]:.2f})")
        exp = plan.expected[h][plan.discriminating[h]]
        ax.plot(*world.positions[exp, :2].T, "x", color=c, ms=7, mew=1.5,
                label=f"expected under {h}, absent under another")
    robot(ax, pose, "k", "true pose", marker="*")
    zoom = fig.add_axes((0.81, 0.07, 0.15, 0.24))   # the poses, 1 m around the truth
    for h, T in enumerate(plan.hypotheses):
        robot(zoom, T, HYP_COLOURS[h % len(HYP_COLOURS)], f"hypothesis {h}", arrow=0.3)
    robot(zoom, pose, "k", "true pose", marker="*", arrow=0.3)
    zoom.set_xlim(pose[0, 3] - 1.0, pose[0, 3] + 1.0)
    zoom.set_ylim(pose[1, 3] - 1.0, pose[1, 3] + 1.0)
    zoom.set_aspect("equal")
    zoom.tick_params(labelsize=6)
    zoom.set_title("the poses, 1 m around the truth", fontsize=8)
    zoom.set_xlabel("x (m)", fontsize=7)
    zoom.set_ylabel("y (m)", fontsize=7)
    ax.set_title(f"before: '{first.status}'; planned gaze (fov {FOV_DEG:g} deg, {MAX_RANGE:g} m) "
                 "under each pose")
    ax = axes[1]
    final = out.result
    # every percept placed by the final pose in its type's colour, the estimate with its 3-sigma
    # ellipse, the truth (worldgraph.figures.plots); the first 5 percepts get a black square around them
    wg.figures.plots.top_view(world, percepts=out.percepts, result=final, ax=ax, types=RECOGNISED, truth=pose,
                      n_hypotheses=0, legend=False)
    if np.all(np.isfinite(final.transformation)):
        T = final.transformation
        old = np.array([p.position for p in percepts])
        ax.plot(*(old @ T[:3, :3].T + T[:3, 3])[:, :2].T, "s", mfc="none", mec="k", ms=11, mew=1.2,
                label="the first 5 percepts")
        wedge(ax, pose[:3, 3], math.atan2(*(pose[:3, :3] @ d)[1::-1]), "k", "the look (true pose)")
    ax.set_title(f"after {out.looks} look(s): '{final.status}'")
    for ax in axes:
        ax.set_xlabel("x (m)")
        ax.set_aspect("equal")
    axes[0].set_ylabel("y (m)")
    axes[1].set_ylabel("")
    handles, labels = [], []
    for ax in axes:
        for hd, lb in zip(*ax.get_legend_handles_labels(), strict=True):
            if lb not in labels:
                handles.append(hd)
                labels.append(lb)
    fig.legend(handles, labels, loc="upper left", bbox_to_anchor=(0.79, 0.97), fontsize=7, frameon=False)
    fig.subplots_adjust(left=0.05, right=0.78, wspace=0.08)
    path = args.out / "07_active_validation.png"
    fig.savefig(path, dpi=120)
    print(f"saved {path}; {time.perf_counter() - t_start:.1f} s")


if __name__ == "__main__":
    main()
