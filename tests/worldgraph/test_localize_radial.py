"""The design card's convex problem inside localize: every returned hypothesis keeps its radial
solution, solved by the solver asked for (the validated ones checked against vertex enumeration
with check=True), through radialopt's unchecked route."""

from __future__ import annotations

import numpy as np
import pytest

import radialopt as ro
from perception.simulation.simulate import simulate_percepts
from worldgraph import scenes
from worldgraph.errors import WorldGraphError
from worldgraph.localization import localize, match_spheres


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
    """certify=True: the ML pose is proven global, and no multi-start finds a lower cost; with
    gravity's tilt prior (the default for a gravity-search answer) the cost proven is that of the
    percepts and the prior, and the multi-starts minimise that cost."""
    import math

    from scipy.spatial.transform import Rotation

    from perception import Percept
    from worldgraph.model import WorldModel
    from worldgraph.pose import refine_pose
    from worldgraph.pose.gravity import TiltPrior
    from worldgraph.pose.validation import percept_covariances, pose_cost
    from worldgraph.tolerances import ASSOCIATION_TOLERANCES

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
        for up_sigma in (math.inf, None):
            prior = None if up_sigma else TiltPrior(np.array([0.0, 0.0, 1.0]),
                                                    ASSOCIATION_TOLERANCES.tilt_allowance / 3.0)
            res = localize(world, percepts, certify=True, max_rotation_3sigma=3.0, max_position_3sigma=10.0,
                           up_sigma=up_sigma)
            assert res.certificate is not None and res.certificate.certified, res.certificate
            x = np.array([p.position for p in percepts])
            covs = percept_covariances(percepts)
            X = world.positions[[o for _, o in sorted(res.correspondences)]]
            x = x[[p for p, _ in sorted(res.correspondences)]]
            covs = covs[[p for p, _ in sorted(res.correspondences)]]

            def cost(T, x=x, covs=covs, X=X, prior=prior):
                return pose_cost(T, x, covs, X) + (prior.cost(T[:3, :3]) if prior is not None else 0.0)

            mine = cost(res.transformation)
            best = np.inf
            for R0 in Rotation.random(30, random_state=trial).as_matrix():
                start = np.eye(4)
                start[:3, :3] = R0
                start[:3, 3] = X.mean(axis=0) - R0 @ x.mean(axis=0)
                T, _ = refine_pose(x, X, covs, start, tilt_prior=prior)
                best = min(best, cost(T))
            assert mine <= best + 1e-7 * max(1.0, best)
            assert res.certificate.lower_bound <= best + 1e-7 * max(1.0, best)
    assert localize(world, percepts).certificate is None
    with pytest.raises(WorldGraphError, match="certify"):
        localize(world, percepts, certify="yes")


def _kitchen_views(count: int, seed: int = 11):
    """Kitchen views of 8-10 percepts (one or two false) from random poses."""
    world = scenes.kitchen(seed=0)
    keep = np.isin(world.types, ["door", "handle", "drawer", "knob"])
    rng = np.random.default_rng(seed)
    lo, hi = world.bounds
    views = []
    while len(views) < count:
        pose = np.eye(4)
        yaw = rng.uniform(-np.pi, np.pi)
        pose[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
        pose[:3, 3] = [*rng.uniform(lo[:2] + 1.0, hi[:2] - 1.0), 1.5]
        percepts, truth = simulate_percepts(list(world.types[keep]), world.positions[keep], pose, rng,
                                            max_range=6.0, n_false=2, false_types=["handle", "knob"])
        true = [p for p, t in zip(percepts, truth, strict=True) if t >= 0]
        false = [p for p, t in zip(percepts, truth, strict=True) if t < 0]
        if len(true) >= 6:
            views.append(true[:int(rng.integers(6, 9))] + false)
    return world, views


def _assert_every_hypothesis_has_its_radial(world, percepts, res, method: str, solver: str | None = None):
    for h in res.hypotheses:
        assert h.radial is not None, (h.all_pairs, res.message)
        assert h.radial.method == method and h.radial.solver == solver
        exact = ro.project_radii(match_spheres(world, percepts, h.all_pairs)[2], method="active_set")
        assert np.max(np.abs(h.radial.radii - exact.radii)) <= 1e-7
        assert h.radial.status == "optimal"


@pytest.mark.parametrize("method", ["ml", "spheres", "paper"])
def test_every_returned_hypothesis_carries_its_radial_solution(kitchen_case, method: str) -> None:
    world, views = _kitchen_views(5)
    views = [kitchen_case[1], *views]  # a view the paper's association matches too
    counted = 0
    for percepts in views:
        res = localize(world, percepts, method)
        _assert_every_hypothesis_has_its_radial(world, percepts, res, "active_set")
        counted += len(res.hypotheses)
    assert counted > (3 * len(views) if method != "paper" else 1)  # not only the validated few
    res = localize(world, views[0], method, solver="CLARABEL")
    _assert_every_hypothesis_has_its_radial(world, views[0], res, "cvxpy", "CLARABEL")


def test_check_true_verifies_the_validated_hypotheses_and_solves_the_others(monkeypatch) -> None:
    import radialopt.projection.project as proj

    world, views = _kitchen_views(1, seed=3)
    verified = []
    real = proj._verify
    monkeypatch.setattr(proj, "_verify",
                        lambda problem, sol, tol: verified.append(sol) or real(problem, sol, tol))
    res = localize(world, views[0], check=True)
    assert len(res.hypotheses) > 1, res.message
    _assert_every_hypothesis_has_its_radial(world, views[0], res, "active_set")
    assert 0 < len(verified) < len(res.hypotheses)  # one enumeration per validated hypothesis


def test_localize_solves_through_the_unchecked_route(monkeypatch) -> None:
    """localize's radial solutions do not re-validate the spheres: radialopt's checking entry
    (project_radii -> sphere_arrays) is never reached, the unchecked route is."""

    import radialopt.projection.project as proj
    from worldgraph.localization import radial as loc
    world, views = _kitchen_views(2, seed=5)
    checks, trusted = [], []
    real_arrays, real_trusted = proj.sphere_arrays, loc.project_radii_unchecked
    monkeypatch.setattr(proj, "sphere_arrays", lambda *a, **k: checks.append(1) or real_arrays(*a, **k))
    monkeypatch.setattr(loc, "project_radii_unchecked",
                        lambda *a, **k: trusted.append(1) or real_trusted(*a, **k))
    for percepts in views:
        res = localize(world, percepts)
        assert all(h.radial is not None for h in res.hypotheses)
    assert trusted and not checks
