"""Shared test problems: seeded generators and hypothesis strategies for radial projection.

Each generator builds valid inputs directly (no filtering): landmarks in a room, a robot
position, measured ranges with sigma = rho^2 / depth_factor noise (eq. 6).
"""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st

import radialopt as ro


def scene(
    rng: np.random.Generator,
    n: int,
    depth_factor: float = 300.0,
    room: float = 5.0,
    noise_scale: float = 1.0,
    min_separation: float = 0.05,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Random landmarks ``(n, 3)``, robot position ``(3,)``, noisy ranges ``(n,)`` and sigmas."""
    while True:
        centers = rng.uniform(-room, room, size=(n, 3))
        d = np.linalg.norm(centers[:, None] - centers[None], axis=-1)
        if np.all(d[np.triu_indices(n, 1)] > min_separation):
            break
    robot = rng.uniform(-room, room, size=3)
    rho = np.linalg.norm(centers - robot, axis=1)
    sigmas = np.maximum(rho**2 / depth_factor, 1e-4)
    radii = np.abs(rho + noise_scale * sigmas * rng.standard_normal(n))
    return centers, robot, radii, sigmas


def infeasible_spheres(rng: np.random.Generator, n: int) -> list[ro.GaussianSphere]:
    """Spheres whose measured radii violate at least one pairwise restriction."""
    while True:
        centers, _, radii, sigmas = scene(rng, n, depth_factor=20.0, room=2.0, noise_scale=3.0)
        P = ro.RestrictionPolytope.from_centers(centers)
        if not P.contains(radii):
            return ro.make_spheres(centers, radii, sigmas)


def four_spheres() -> list[ro.GaussianSphere]:
    """Four spheres of a valid problem (centres, radii, sigmas written out)."""
    return ro.make_spheres([[0, 0, 0], [4, 0, 0], [0, 3, 0.5], [1, 1, 3]], [1.9, 3.4, 2.1, 2.3],
                           [0.1, 0.2, 0.05, 0.3])


def sphere_arrays(spheres):
    """The centres, radii and sigmas of ``spheres`` as three arrays."""
    return (np.array([s.center for s in spheres]), np.array([s.radius for s in spheres]),
            np.array([s.sigma for s in spheres]))


@st.composite
def sphere_sets(draw, min_n: int = 2, max_n: int = 6, scale: float = 5.0):
    """Hypothesis strategy: n spheres with distinct centres, radii >= 0 and sigmas > 0."""
    n = draw(st.integers(min_n, max_n))
    coord = st.floats(-scale, scale, allow_nan=False, allow_infinity=False)
    centers = []
    while len(centers) < n:
        c = np.array([draw(coord) for _ in range(3)])
        if all(np.linalg.norm(c - o) > 1e-2 for o in centers):
            centers.append(c)
        else:  # move a coincident draw deterministically instead of rejecting it
            centers.append(c + 0.1 * (len(centers) + 1) * np.array([1.0, 0.5, 0.25]))
    radii = [draw(st.floats(0.0, 3 * scale)) for _ in range(n)]
    sigmas = [draw(st.floats(1e-3, 2.0)) for _ in range(n)]
    return ro.make_spheres(np.array(centers), np.array(radii), np.array(sigmas))


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A uniformly random rotation matrix (QR of a Gaussian matrix, sign-fixed)."""
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


def robot_at_a_table(site, seed: int, n_true: int) -> tuple[np.ndarray, list]:
    """A robot of a :class:`worldgraph.scenes.Site` 0.8 m above a random table, random yaw, and
    ``n_true`` true percepts of its building's storey within 8 m (sigma = rho^2 / 1000) plus one
    false percept, shuffled: ``(world_from_ego, percepts)``."""
    from scipy.spatial.transform import Rotation

    from perception.simulation.simulate import simulate_percepts

    rng = np.random.default_rng(seed)
    w = site.world
    tables = np.flatnonzero(w.types == "table")
    while True:
        table = tables[rng.integers(len(tables))]
        pose = np.eye(4)
        pose[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * np.pi)).as_matrix()
        pose[:3, 3] = w.positions[table] + [0.0, 0.0, 0.8]
        mask = (site.storey == site.storey[table]) & (site.building == site.building[table])
        types = list(w.types[mask])
        percepts, truth = simulate_percepts(types, w.positions[mask], pose, rng, depth_factor=1000.0,
                                            max_range=8.0, n_false=1, false_types=sorted(set(types)))
        true_idx = np.flatnonzero(truth >= 0)
        if len(true_idx) >= n_true:
            pick = np.concatenate([rng.choice(true_idx, n_true, replace=False), np.flatnonzero(truth < 0)])
            return pose, [percepts[i] for i in rng.permutation(pick)]
