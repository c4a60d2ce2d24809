"""The design card's convex problem inside localize: every validated hypothesis keeps its radial
solution, solved by the solver asked for and checked against vertex enumeration."""

from __future__ import annotations

import numpy as np
import pytest

import radialopt as ro
from perception.simulate import simulate_percepts
from worldgraph import scenes
from worldgraph.errors import WorldGraphError
from worldgraph.localize import localize, match_spheres


@pytest.fixture(scope="module")
def kitchen_case():
    world = scenes.kitchen(seed=0)
    rng = np.random.default_rng(4)
    pose = np.eye(4)
    pose[:3, 3] = [5.0, 3.0, 1.5]
    keep = np.isin(world.types, ["door", "handle", "drawer", "knob"])
    percepts, _ = simulate_percepts(list(world.types[keep]), world.positions[keep], pose, rng,
                                    max_range=6.0, n_false=1, false_types=["handle", "knob"])
    return world, percepts[:5] + percepts[-1:], pose  # <= 6 spheres: vertex enumeration stays fast


@pytest.mark.parametrize("method", ["ml", "spheres", "paper"])
def test_clarabel_with_vertex_check_on_every_evaluated_hypothesis(kitchen_case, method: str) -> None:
    world, percepts, pose = kitchen_case
    res = localize(world, percepts, method, solver="CLARABEL", check=True)
    evaluated = [h for h in res.hypotheses if h.radial is not None]
    assert evaluated, res.message
    if method != "paper":
        assert res.hypotheses[0].radial is not None
    for h in evaluated:
        assert h.radial.method == "cvxpy" and h.radial.solver == "CLARABEL"
        exact = ro.project_radii(match_spheres(world, percepts, h.all_pairs)[2], method="active_set")
        assert np.max(np.abs(h.radial.radii - exact.radii)) <= 1e-7
        assert h.radial.status == "optimal"
    assert res.timings["radial"] > 0.0


def test_active_set_is_the_default_and_bad_solvers_raise(kitchen_case) -> None:
    world, percepts, _ = kitchen_case
    res = localize(world, percepts)
    assert res.hypotheses[0].radial.method == "active_set"
    assert np.isfinite(res.hypotheses[0].radial.normalized_displacement)
    with pytest.raises(WorldGraphError, match="NO_SUCH_SOLVER"):
        localize(world, percepts, solver="NO_SUCH_SOLVER")
    with pytest.raises(WorldGraphError, match="check"):
        localize(world, percepts, check="yes")
    with pytest.raises(WorldGraphError, match="solver"):
        localize(world, percepts, solver=3)


def test_localize_certificate_agrees_with_brute_force_multistart() -> None:
    """certify=True: the ML pose is proven global, and no multi-start finds a lower cost."""
    from scipy.spatial.transform import Rotation

    from perception import Percept
    from worldgraph.model import WorldModel
    from worldgraph.pose import refine_pose
    from worldgraph.validation import percept_covariances, pose_cost

    rng = np.random.default_rng(12)
    for trial in range(4):
        n = 4 + trial
        world = WorldModel.from_arrays([f"t{k}" for k in range(n)],
                                       rng.uniform([0, 0, 0], [4, 4, 2.5], (n, 3)))
        pose = np.eye(4)
        pose[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * np.pi)).as_matrix()
        pose[:3, 3] = [2.0, -2.5, 1.5]
        ego = (world.positions - pose[:3, 3]) @ pose[:3, :3]
        sig = 0.05
        percepts = [Percept(str(t), e + rng.normal(0, sig, 3), sig)
                    for t, e in zip(world.types, ego, strict=True)]
        res = localize(world, percepts, certify=True, max_rotation_3sigma=3.0, max_position_3sigma=10.0)
        assert res.certificate is not None and res.certificate.certified, res.certificate
        x = np.array([p.position for p in percepts])
        covs = percept_covariances(percepts)
        X = world.positions[[o for _, o in sorted(res.correspondences)]]
        x = x[[p for p, _ in sorted(res.correspondences)]]
        covs = covs[[p for p, _ in sorted(res.correspondences)]]
        mine = pose_cost(res.transformation, x, covs, X)
        best = np.inf
        for R0 in Rotation.random(30, random_state=trial).as_matrix():
            start = np.eye(4)
            start[:3, :3] = R0
            start[:3, 3] = X.mean(axis=0) - R0 @ x.mean(axis=0)
            T, _ = refine_pose(x, X, covs, start)
            best = min(best, pose_cost(T, x, covs, X))
        assert mine <= best + 1e-7 * max(1.0, best)
        assert res.certificate.lower_bound <= best + 1e-7 * max(1.0, best)
    assert localize(world, percepts).certificate is None
    with pytest.raises(WorldGraphError, match="certify"):
        localize(world, percepts, certify="yes")
