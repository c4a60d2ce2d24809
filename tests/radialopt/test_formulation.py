"""RadialProblem: the DPP cvxpy formulation (l2 / l1 / Huber) with added constraints."""

import numpy as np
import pytest

import radialopt as ro
from radialopt.formulation import RadialProblem
from tests.problems import infeasible_spheres


def test_l2_matches_the_active_set_and_reuses_one_compilation():
    rng = np.random.default_rng(3)
    rp = RadialProblem(5)
    assert rp.problem.is_dpp()
    first = None
    for _ in range(3):
        spheres = infeasible_spheres(rng, 5)
        sol = rp.solve(spheres)
        exact = ro.project_radii(spheres)
        assert sol.status == "optimal"
        np.testing.assert_allclose(sol.radii, exact.radii, atol=1e-6)
        assert sol.density == pytest.approx(exact.density, rel=1e-5)
        cache = rp.problem._cache.param_prog
        first = cache if first is None else first
        assert cache is first  # compiled on the first solve, re-used after
    assert rp.compilations == 1


@pytest.mark.parametrize("objective", ["l1", "huber"])
def test_robust_objectives_give_feasible_radii(objective):
    spheres = infeasible_spheres(np.random.default_rng(4), 4)
    sol = RadialProblem(4, objective=objective, huber_delta=0.5).solve(spheres)
    P = ro.RestrictionPolytope.from_spheres(spheres)
    assert sol.status == "optimal"
    assert P.contains(sol.radii, tol=1e-6)
    assert sol.method == f"formulation:{objective}"


def test_l1_leaves_good_ranges_and_moves_the_bad_one():
    rng = np.random.default_rng(0)
    centers = rng.uniform(-1, 1, size=(6, 3))
    robot = np.array([5.0, 0.3, -0.2])
    r = np.linalg.norm(centers - robot, axis=1) + 0.01 * rng.standard_normal(6)
    r[2] += 3.0  # one grossly wrong range
    spheres = ro.make_spheres(centers, r, 0.02)
    l1 = RadialProblem(6, "l1").solve(spheres)
    l2 = ro.project_radii(spheres)
    good = np.delete(np.arange(6), 2)
    assert np.max(np.abs(l1.displacement[good])) < np.max(np.abs(l2.displacement[good]))
    assert abs(l1.displacement[2]) > abs(l2.displacement[2])


def test_bounds_and_fixed_radius_are_honoured():
    spheres = infeasible_spheres(np.random.default_rng(5), 4)
    free = ro.project_radii(spheres)
    rp = RadialProblem(4)
    k = int(np.argmax(np.abs(free.displacement)))
    v = float(free.radii[k] - 0.5 * free.displacement[k])
    rp.fix_radius(k, v)
    assert rp.compilations == 2
    sol = rp.solve(spheres)
    assert sol.radii[k] == pytest.approx(v, abs=1e-7)
    rp.bound_radii(0.0, float(np.max(free.radii)) + 1.0)
    sol2 = rp.solve(spheres)
    assert np.all(sol2.radii >= -1e-8) and sol2.radii[k] == pytest.approx(v, abs=1e-7)
    rp3 = RadialProblem(4).add_constraint(lambda x: x[0] + x[1] <= float(free.radii[:2].sum()) - 0.1)
    s3 = rp3.solve(spheres)
    assert s3.radii[0] + s3.radii[1] <= free.radii[:2].sum() - 0.1 + 1e-7


def test_infeasible_added_constraints_raise_solver_error():
    spheres = ro.make_spheres([[0, 0, 0], [10, 0, 0]], [4.0, 4.0], 0.5)
    rp = RadialProblem(2).fix_radius(0, 1.0).fix_radius(1, 1.0)  # cannot reach d = 10
    with pytest.raises(ro.SolverError, match="infeasible"):
        rp.solve(spheres)


@pytest.mark.parametrize(
    ("call", "error", "word"),
    [
        (lambda: RadialProblem(1), ro.RadialError, "n must be >= 2 spheres"),
        (lambda: RadialProblem(2.5), ro.RadialError, "n must be an integer"),
        (lambda: RadialProblem(3, objective="l3"), ro.RadialError, "unknown objective='l3'"),
        (lambda: RadialProblem(3, "huber", huber_delta=0), ro.RadialError,
         "huber_delta must be > 0, got 0.0"),
        (lambda: RadialProblem(3).fix_radius(3, 1.0), ro.RadialError, "i = 3 must be a sphere index"),
        (lambda: RadialProblem(3).fix_radius(0, float("nan")), ro.RadialError,
         "value must be finite, got nan"),
        (lambda: RadialProblem(3).fix_radius(0, -1.0), ro.RadialError, "value must be >= 0, got -1.0"),
        (lambda: RadialProblem(3).bound_radii(2.0, 1.0), ro.RadialError, "lo must be <= hi"),
        (lambda: RadialProblem(3).bound_radii([0, 1], 2.0), ro.RadialError,
         r"lo must be a scalar or shape \(3,\)"),
        (lambda: RadialProblem(3).add_constraint(lambda x: 3), ro.RadialError,
         "fn must return cvxpy constraints"),
        (lambda: RadialProblem(3).solve(ro.make_spheres([[0, 0, 0], [1, 0, 0]], [1, 1], 0.1)),
         ro.RadialError, "spheres must be a sequence of 3 GaussianSphere"),
        (lambda: RadialProblem(2).solve(ro.make_spheres([[0, 0, 0], [1, 0, 0]], [1, 1], 0.1),
                                        solver="NOPE"), ro.RadialError,
         "solver='NOPE' is not an installed cvxpy solver"),
    ],
)
def test_bad_input_names_the_argument(call, error, word):
    with pytest.raises(error, match=rf"^{word}"):  # the message starts with the argument's name
        call()


def test_ecos_status_maps_like_project_radii():
    if "ECOS" not in ro.installed_cvxpy_solvers():
        pytest.skip("ECOS not installed")
    spheres = infeasible_spheres(np.random.default_rng(8), 3)
    sol = RadialProblem(3).solve(spheres, solver="ECOS")
    assert sol.status in ("optimal", "optimal_inaccurate") and sol.solver == "ECOS"
