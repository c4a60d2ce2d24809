"""
Gaussian circles: the sum and product densities of three 2D Gaussian spheres (paper Figs. 12-13)
================================================================================================

Run it from the repository root::

    python examples/01_gaussian_circles.py [--out out]

Three circles with noisy radii do not meet in one point; the product density (eq. 14) still
has a clear maximum, found here by the maximum-likelihood estimator, and shown beside the sum
density (Fig. 12b) that the paper uses to visualise where the peaks lie.
"""

from __future__ import annotations

import numpy as np
from _common import parse_args, pyplot

import radialopt as ro


def main() -> None:
    args = parse_args(__doc__)
    plt = pyplot()
    centers = np.array([[0.0, 0.0, 0.0], [4.0, 0.5, 0.0], [1.5, 3.5, 0.0]])
    truth = np.array([2.2, 1.4, 0.0])
    rng = np.random.default_rng(args.seed)
    sigmas = np.array([0.25, 0.35, 0.3])
    radii = np.linalg.norm(centers - truth, axis=1) + sigmas * rng.standard_normal(3)
    spheres = ro.make_spheres(centers, radii, sigmas)

    k = 150 if args.smoke else 500
    xs = np.linspace(-2.5, 6.5, k)
    ys = np.linspace(-2.5, 6.5, k)
    X, Y = np.meshgrid(xs, ys)
    pts = np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], axis=1)
    total_sum = sum(ro.density(s, pts) for s in spheres).reshape(X.shape)
    product = ro.total_density(spheres, pts).reshape(X.shape)

    grid_best = pts[np.argmax(product)]
    est = ro.estimate_position(spheres, method="ml", region=ro.Region((-10, -10, -1e-9),
                                                                        (10, 10, 1e-9)))
    best = est.position
    print(f"grid maximum of the product density: {grid_best[:2].round(3)}  "
          f"density {ro.total_density(spheres, grid_best):.4f}")
    print(f"ML estimate:                          {best[:2].round(3)}  "
          f"density {ro.total_density(spheres, best):.4f}  (truth {truth[:2]})")

    fig, axes = plt.subplots(1, 2, figsize=(11, 5), constrained_layout=True)
    for ax, field, title in (
        (axes[0], total_sum, "sum of densities (Fig. 12b)"),
        (axes[1], product, "product density, eq. 14 (Fig. 13b)"),
    ):
        im = ax.imshow(field, origin="lower", extent=(xs[0], xs[-1], ys[0], ys[-1]), cmap="magma")
        fig.colorbar(im, ax=ax, shrink=0.8, label="density at z = 0")
        for c, r in zip(centers, radii, strict=True):
            ax.add_patch(plt.Circle(c[:2], r, fill=False, color="cyan", lw=0.8, ls="--"))
            ax.plot(*c[:2], "c+", label="circle centres, radii (dashed)")
        ax.plot(*truth[:2], "X", mfc="white", mec="black", ms=9, label="truth")
        ax.plot(*best[:2], "o", mfc="none", mec="lime", ms=10, label="maximum (ML)")
        ax.set_title(title)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        handles, labels = ax.get_legend_handles_labels()
        unique = dict(zip(labels, handles, strict=True))
        ax.legend(unique.values(), unique.keys(), loc="upper center", bbox_to_anchor=(0.5, -0.13),
                  ncol=3, fontsize=8, frameon=False)
    path = args.out / "01_gaussian_circles.png"
    fig.savefig(path, dpi=80, bbox_inches="tight")
    print(f"saved {path}")


if __name__ == "__main__":
    main()
