"""The design card's convex problem inside localize: every validated hypothesis keeps its radial
solution, solved by the solver asked for and checked against vertex enumeration."""

from __future__ import annotations

import numpy as np
import pytest

import radialopt as ro
from perception.simulate import simulate_percepts
from worldgraph import scenes
from worldgraph.errors import WorldGraphError
from worldgraph.localize import localize


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


def spheres_of(world, percepts, h):
    pairs = []
    for p, o in h.all_pairs:
        if all(np.linalg.norm(world.positions[o] - world.positions[q]) > 1e-9 for _, q in pairs):
            pairs.append((p, o))
    pairs.sort()
    return ro.make_spheres(world.positions[[o for _, o in pairs]],
                           [percepts[p].range for p, _ in pairs], [percepts[p].sigma for p, _ in pairs])


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
        exact = ro.project_radii(spheres_of(world, percepts, h), method="active_set")
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
