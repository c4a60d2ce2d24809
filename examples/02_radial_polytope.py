"""
The radial configuration space of 2 and 3 spheres (paper Figs. 14-15)
=====================================================================

Run it from the repository root::

    python examples/02_radial_polytope.py [--out out]

Left: two spheres in normalised radial space Sd^2: the restriction lines L_chi, L_alpha,
L_beta, the region K_meet where the spheres intersect, a measured configuration outside it
and its normalised projection.  Right: three spheres in Sd^3: the vertices and edges of the
open polytope from explicit vertex enumeration, the measured configuration and the projection
by each method.
"""

from __future__ import annotations

import itertools

import numpy as np
from _common import parse_args, pyplot

import radialopt as ro


def two_spheres(ax) -> None:
    spheres = ro.make_spheres([[0, 0, 0], [3, 0, 0]], [0.8, 1.1], [0.2, 0.3])
    Pd = ro.RestrictionPolytope.from_spheres(spheres).normalized()
    sig = Pd.sigmas
    x0 = np.array([s.radius for s in spheres]) / sig
    exact = ro.project_radii(spheres).radii / sig
    paper = ro.project_radii(spheres, method="paper").radii / sig
    g = np.linspace(0, 25, 400)
    X, Y = np.meshgrid(g, g)
    inside = Pd.contains(np.stack([X.ravel(), Y.ravel()], axis=1), tol=0).reshape(X.shape)
    ax.contourf(X, Y, inside, levels=[0.5, 1.5], colors=["#cde8c9"])
    for k, name in enumerate(Pd.kinds):
        a, b = Pd.A[k], Pd.b[k]
        if abs(a[1]) > 1e-12:
            ax.plot(g, (b - a[0] * g) / a[1], lw=1, label=f"L_{name}")
    ax.plot(*x0, "ko", label="measured")
    ax.plot(*exact, "g*", ms=12, label=f"projection ({ro.project_radii(spheres).density:.3f})")
    ax.plot(*paper, "r+", ms=12, label="eq. 17")
    ax.annotate("", exact, x0, arrowprops={"arrowstyle": "->"})
    ax.set(xlim=(0, 25), ylim=(0, 25), xlabel="r1 / sigma1", ylabel="r2 / sigma2",
           title="two spheres in Sd^2: K_meet shaded")
    ax.set_aspect("equal")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=3, frameon=False)


def three_spheres(ax, rng: np.random.Generator) -> None:
    centers = np.array([[0, 0, 0], [2.0, 0.3, 0], [0.8, 1.7, 0.4]])
    sig = np.array([0.15, 0.2, 0.25])
    radii = np.array([0.5, 0.6, 2.6])
    spheres = ro.make_spheres(centers, radii, sig)
    P = ro.RestrictionPolytope.from_spheres(spheres)
    enum = ro.enumerate_vertices(P.normalized())
    V = enum.vertices
    # an edge joins two vertices that share n - 1 = 2 tight rows
    act = enum.vertex_active
    for i, j in itertools.combinations(range(len(V)), 2):
        if np.sum(act[i] & act[j]) >= 2:
            ax.plot(*V[[i, j]].T, color="0.4", lw=1)
    for v in V:
        ray = v + 12 * enum.rays[0]
        ax.plot(*np.stack([v, ray]).T, color="0.7", lw=0.8, ls=":")
    ax.scatter(*V.T, color="k", s=12, label=f"{len(V)} vertices")
    x0 = radii / sig
    ax.scatter(*x0, color="b", s=30, label="measured")
    for method, marker in (("active_set", "*"), ("paper", "+")):
        sol = ro.project_radii(spheres, method=method)
        ax.scatter(*(sol.radii / sig), marker=marker, s=120,
                   label=f"{method} (density {sol.density:.3f})")
    ax.set(xlabel="r1/s1", ylabel="r2/s2", zlabel="r3/s3", title="three spheres in Sd^3")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.02), ncol=2, frameon=False)


def main() -> None:
    args = parse_args(__doc__)
    plt = pyplot()
    fig = plt.figure(figsize=(12, 5.5), constrained_layout=True)
    two_spheres(fig.add_subplot(1, 2, 1))
    three_spheres(fig.add_subplot(1, 2, 2, projection="3d"), np.random.default_rng(args.seed))
    path = args.out / "02_radial_polytope.png"
    fig.savefig(path, dpi=80, bbox_inches="tight")
    print(f"saved {path}")


if __name__ == "__main__":
    main()
