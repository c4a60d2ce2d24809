"""project_radii: every method against the others and against the optimality conditions."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.optimize import nnls

import radialopt as ro
from radialopt.projection import least_distance
from tests.problems import infeasible_spheres, random_rotation, scene, sphere_sets

EXACT = ("active_set", "vertices")


def cost(spheres, radii):
    r = np.array([s.radius for s in spheres])
    sig = np.array([s.sigma for s in spheres])
    return float(np.sum(((radii - r) / sig) ** 2))


def polytope_of(spheres):
    return ro.RestrictionPolytope.from_spheres(spheres)


@given(sphere_sets(min_n=2, max_n=5))
def test_output_in_polytope_and_projection_is_idempotent(spheres):
    sol = ro.project_radii(spheres)
    P = polytope_of(spheres)
    assert P.contains(sol.radii, tol=1e-9 * max(1.0, np.abs(P.b).max()))
    again = ro.project_radii([s.with_radius(r) for s, r in zip(spheres, sol.radii, strict=True)])
    np.testing.assert_allclose(again.radii, sol.radii, atol=1e-9)
    assert 0.0 <= sol.density <= 1.0
    assert sol.normalized_displacement**2 == pytest.approx(cost(spheres, sol.radii), rel=1e-9)
    assert sol.density == pytest.approx(np.exp(-0.5 * cost(spheres, sol.radii)), rel=1e-9)


@given(sphere_sets(min_n=2, max_n=5))
def test_feasible_input_is_returned_unchanged_with_density_one(spheres):
    P = polytope_of(spheres)
    r = np.array([s.radius for s in spheres])
    if not P.contains(r, tol=0):
        # move to a feasible configuration by hand: the true ranges of a real point
        x = np.mean([s.center for s in spheres], axis=0) + 0.37
        r = np.linalg.norm(np.array([s.center for s in spheres]) - x, axis=1)
        spheres = [s.with_radius(ri) for s, ri in zip(spheres, r, strict=True)]
    for method in ("active_set", "cvxpy", "paper"):
        sol = ro.project_radii(spheres, method=method)
        np.testing.assert_allclose(sol.radii, r, atol=1e-8 if method == "cvxpy" else 0)
        assert sol.density == pytest.approx(1.0, abs=1e-12)


@given(sphere_sets(min_n=2, max_n=5))
def test_exact_methods_agree_and_cvxpy_agrees(spheres):
    ref = ro.project_radii(spheres, method="active_set")
    for method in EXACT[1:]:
        other = ro.project_radii(spheres, method=method)
        np.testing.assert_allclose(other.radii, ref.radii, atol=1e-9)
    cv = ro.project_radii(spheres, method="cvxpy", solver="CLARABEL")
    # Clarabel meets 1e-7 m; with sigmas spread over more than two decades the interior-point
    # answer drifts further on degenerate faces, roughly with the squared sigma ratio
    # (measured: 1.5e-7 m at a ratio of 256, 1.5e-6 m at 1000).
    sig = np.array([s.sigma for s in spheres])
    atol = max(1e-7, 3e-12 * (sig.max() / sig.min()) ** 2)
    np.testing.assert_allclose(cv.radii, ref.radii, atol=atol)
    assert cv.status in ("optimal", "optimal_inaccurate")


@pytest.mark.parametrize("n", range(3, 9))
def test_methods_agree_on_infeasible_scenes(n):
    rng = np.random.default_rng(100 + n)
    for _ in range(4 if n <= 6 else 1):
        spheres = infeasible_spheres(rng, n)
        ref = ro.project_radii(spheres, method="active_set", check=n <= 6)
        assert ref.density < 1.0
        cv = ro.project_radii(spheres, method="cvxpy")
        np.testing.assert_allclose(cv.radii, ref.radii, atol=1e-7)
        paper = ro.project_radii(spheres, method="paper")
        assert cost(spheres, paper.radii) >= cost(spheres, ref.radii) * (1 - 1e-9) - 1e-12
        if n <= 6:
            vert = ro.project_radii(spheres, method="vertices")
            np.testing.assert_allclose(vert.radii, ref.radii, atol=1e-9)


@given(sphere_sets(min_n=2, max_n=6))
def test_kkt_conditions_hold(spheres):
    sol = ro.project_radii(spheres)
    P = polytope_of(spheres)
    r = np.array([s.radius for s in spheres])
    sig = np.array([s.sigma for s in spheres])
    # stationarity: H^2 (r' - r) = -A_act^T lambda with lambda >= 0 on the active rows
    grad = (sol.radii - r) / sig**2
    scale = max(1.0, np.abs(P.b).max())
    active = np.flatnonzero(np.abs(P.b - P.A @ sol.radii) <= 1e-7 * scale)
    if active.size == 0:
        np.testing.assert_allclose(grad, 0, atol=1e-9)
        return
    lam, resid = nnls(-P.A[active].T, grad)
    assert resid <= 1e-6 * max(1.0, np.linalg.norm(grad))


@given(sphere_sets(min_n=2, max_n=6), st.randoms(use_true_random=False))
def test_permutation_invariance(spheres, random):
    perm = list(range(len(spheres)))
    random.shuffle(perm)
    a = ro.project_radii(spheres)
    b = ro.project_radii([spheres[i] for i in perm])
    np.testing.assert_allclose(b.radii, a.radii[perm], atol=1e-9)


@given(sphere_sets(min_n=2, max_n=6), st.integers(0, 2**32 - 1))
def test_rigid_motion_invariance(spheres, seed):
    rng = np.random.default_rng(seed)
    R, t = random_rotation(rng), rng.uniform(-100, 100, 3)
    moved = [ro.GaussianSphere(R @ s.center + t, s.radius, s.sigma) for s in spheres]
    np.testing.assert_allclose(ro.project_radii(moved).radii, ro.project_radii(spheres).radii,
                               atol=1e-8)


@given(sphere_sets(min_n=2, max_n=5), st.data())
def test_larger_sigma_moves_its_radius_at_least_as_far(spheres, data):
    k = data.draw(st.integers(0, len(spheres) - 1))
    factor = data.draw(st.floats(1.1, 20))
    a = ro.project_radii(spheres)
    wider = list(spheres)
    wider[k] = ro.GaussianSphere(spheres[k].center, spheres[k].radius, spheres[k].sigma * factor)
    b = ro.project_radii(wider)
    assert abs(b.displacement[k]) >= abs(a.displacement[k]) - 1e-9


@given(sphere_sets(min_n=2, max_n=5))
def test_paper_is_never_better_than_exact(spheres):
    exact = ro.project_radii(spheres, method="active_set")
    paper = ro.project_radii(spheres, method="paper")
    P = polytope_of(spheres)
    assert P.contains(paper.radii, tol=1e-8 * max(1.0, np.abs(P.b).max()))
    c_exact = cost(spheres, exact.radii)
    assert cost(spheres, paper.radii) >= c_exact - 1e-9 * max(1.0, c_exact)
    assert paper.density <= exact.density * (1 + 1e-9) + 1e-12


def test_paper_is_not_optimal_on_a_ridge():
    """Eq. 17 on the violated rows stops at the first flat size with a feasible projection;
    when that flat's KKT multipliers are not all >= 0 it loses to the optimum and says so
    with status "optimal_inaccurate" (was: every answer "optimal", from flats of any rows)."""
    rng = np.random.default_rng(5)
    worse = 0
    for _ in range(60):
        spheres = infeasible_spheres(rng, 6)
        exact = ro.project_radii(spheres)
        paper = ro.project_radii(spheres, method="paper")
        lost = cost(spheres, paper.radii) > cost(spheres, exact.radii) + 1e-6
        worse += lost
        assert paper.status == ("optimal_inaccurate" if lost else "optimal")
    assert worse > 0


def test_two_spheres_apart_meet_halfway_in_sigma_units():
    # d = 10, r = (4, 4), equal sigma: each grows by 1 to touch
    spheres = ro.make_spheres([[0, 0, 0], [10, 0, 0]], [4.0, 4.0], [0.5, 0.5])
    sol = ro.project_radii(spheres)
    np.testing.assert_allclose(sol.radii, [5.0, 5.0], atol=1e-12)
    # unequal sigma: the displacement splits in proportion to sigma^2
    sol = ro.project_radii(ro.make_spheres([[0, 0, 0], [10, 0, 0]], [4.0, 4.0], [1.0, 2.0]))
    np.testing.assert_allclose(sol.displacement, [2 * 1 / 5, 2 * 4 / 5], atol=1e-12)


def test_least_distance_reports_infeasible_constraints():
    G = np.array([[1.0], [-1.0]])
    h = np.array([-1.0, -1.0])  # z <= -1 and z >= 1
    z, status = least_distance(G, h)
    assert status == "infeasible"


def test_check_true_accepts_every_exact_method():
    rng = np.random.default_rng(9)
    spheres = infeasible_spheres(rng, 4)
    for method in ("active_set", "cvxpy", "vertices", "paper"):
        assert ro.project_radii(spheres, method=method, check=True).status == "optimal"


def test_verification_rejects_a_wrong_answer():
    from radialopt.projection import verify_solution

    rng = np.random.default_rng(11)
    spheres = infeasible_spheres(rng, 4)
    sol = ro.project_radii(spheres)
    bad = ro.RadialSolution(sol.radii + 0.01, sol.displacement + 0.01, sol.density, "optimal",
                            "active_set", None, 0.0)
    with pytest.raises(ro.VerificationError, match="differ|violate"):
        verify_solution(spheres, bad)


def test_unknown_method_and_solver_errors_list_the_choices():
    spheres = ro.make_spheres([[0, 0, 0], [1, 0, 0]], [0.2, 0.2], 0.1)
    with pytest.raises(ro.RadialError, match=r"unknown method 'simplex'; choose one of.*active_set"):
        ro.project_radii(spheres, method="simplex")
    with pytest.raises(ro.RadialError, match=r"solver = 'NO_SUCH_SOLVER' is not.*CLARABEL"):
        ro.project_radii(spheres, method="cvxpy", solver="NO_SUCH_SOLVER")
    with pytest.raises(ro.RadialError, match="only applies"):
        ro.project_radii(spheres, method="active_set", solver="CLARABEL")


@pytest.mark.parametrize(
    ("spheres", "error", "message"),
    [
        ([ro.GaussianSphere((0, 0, 0), 1, 1)], ro.RadialError, "need at least 2 spheres, got 1"),
        ([ro.GaussianSphere((0, 0, 0), 1, 1), ro.GaussianSphere((0, 0, 0), 2, 1)],
         ro.RadialError, "centres 0 and 1 coincide"),
        ([ro.GaussianSphere((0, 0, 0), 1, 1), (1.0, 2.0, 3.0)], ro.RadialError,
         r"spheres\[1\] must be a GaussianSphere, got tuple"),
    ],
)
def test_bad_input_raises_specific_errors(spheres, error, message):
    with pytest.raises(error, match=message):
        ro.project_radii(spheres)


def test_make_spheres_validates_shapes():
    with pytest.raises(ro.RadialError, match=r"radii must have shape.*\(3,\)"):
        ro.make_spheres(np.zeros((3, 3)), [1, 2], 0.1)
    with pytest.raises(ro.RadialError, match=r"sigmas\[1\] = -0.1 must be > 0"):
        ro.make_spheres(np.eye(3), [1, 2, 3], [0.1, -0.1, 0.1])


def test_solution_status_and_timing_fields():
    rng = np.random.default_rng(2)
    centers, _, radii, sig = scene(rng, 5)
    sol = ro.project_radii(ro.make_spheres(centers, radii, sig), method="cvxpy")
    assert sol.solver == "CLARABEL" and sol.method == "cvxpy"
    assert sol.status in ro.STATUSES and sol.solve_time > 0


def test_batch_matches_single_calls():
    rng = np.random.default_rng(21)
    batch = [infeasible_spheres(rng, 5) for _ in range(6)]
    centers, robot, _, sig = scene(rng, 5)  # one feasible instance: the true ranges
    batch.append(ro.make_spheres(centers, np.linalg.norm(centers - robot, axis=1), sig))
    C = np.array([[s.center for s in b] for b in batch])
    R = np.array([[s.radius for s in b] for b in batch])
    S = np.array([[s.sigma for s in b] for b in batch])
    out = ro.project_radii_batch(C, R, S)
    for k, b in enumerate(batch):
        single = ro.project_radii(b)
        np.testing.assert_allclose(out.radii[k], single.radii, atol=1e-12)
        assert out.density[k] == pytest.approx(single.density, rel=1e-12, abs=1e-300)
    with pytest.raises(ro.RadialError, match=r"sigmas\[0, 0\] = -"):
        ro.project_radii_batch(C, R, -S)
    with pytest.raises(ro.RadialError, match=r"centers must have shape"):
        ro.project_radii_batch(C[:, :, :2], R, S)
    R2 = R.copy()
    R2[1, 2] = np.nan
    with pytest.raises(ro.RadialError, match=r"\[1, 2\]"):
        ro.project_radii_batch(C, R2, S)


def test_osqp_solve_writes_nothing_to_stdout(capfd):
    """OSQP 1.x prints a line per solve from C when no constraint is active (osqp#785); a
    projection must stay quiet and still return the target when it is already feasible."""
    if "OSQP" not in ro.installed_cvxpy_solvers():
        pytest.skip("OSQP is not installed")
    centers = np.array([[0.0, 0, 0], [4, 0, 0], [0, 4, 0], [0, 0, 4]])
    radii = np.linalg.norm(centers - np.array([1.0, 1.0, 1.0]), axis=1)
    sol = ro.project_radii(ro.make_spheres(centers, radii, [0.1] * 4), method="cvxpy", solver="OSQP")
    np.testing.assert_allclose(sol.radii, radii, atol=1e-9)
    assert capfd.readouterr().out == ""


def hard_spheres(seed, n=8, ratio=27.0, s0=1e-4, gross=10.0):
    """Badly inconsistent 8-sphere instances, sigma ratio 27: ranges off by metres with
    sigmas of 0.1-2.7 mm, so the optimum lies ~1e4-1e5 sigma from the measurement."""
    rng = np.random.default_rng(seed)
    centers = rng.uniform(-3, 3, size=(n, 3)) + rng.uniform(0, 0, 3)
    robot = centers.mean(0) + rng.uniform(-3, 3, size=3)
    rho = np.linalg.norm(centers - robot, axis=1)
    sig = s0 * ratio ** rng.uniform(0, 1, n)
    sig[0], sig[1] = s0, s0 * ratio
    radii = np.abs(rho + 20 * sig * rng.standard_normal(n) + gross * rng.standard_normal(n))
    return ro.make_spheres(centers, radii, sig)


#: Seeds on which unscaled, unpolished Clarabel missed the exact answer by 1.7e-5, 1.5e-6 and
#: 1.3e-6 m while reporting "optimal".
HARD_SEEDS = (26, 46, 49)


@pytest.mark.parametrize("seed", HARD_SEEDS)
def test_clarabel_matches_active_set_on_hard_instances(seed):
    spheres = hard_spheres(seed)
    exact = ro.project_radii(spheres)
    cv = ro.project_radii(spheres, method="cvxpy", solver="CLARABEL")
    assert cv.status == "optimal"
    assert np.max(np.abs(cv.radii - exact.radii)) <= 1e-7
    if seed == HARD_SEEDS[0]:
        # the vertex-enumeration check takes ~23 s for these 8 spheres, so it is refused beyond
        # MAX_VERTEX_SPHERES = 7; the 7-sphere instance of the same seed is checked instead
        with pytest.raises(ro.RadialError, match=r"spheres \(check=True enumerates.*MAX_VERTEX_SPHERES"):
            ro.project_radii(spheres, method="cvxpy", solver="CLARABEL", check=True)
        seven = hard_spheres(seed, n=ro.MAX_VERTEX_SPHERES)
        assert ro.project_radii(seven, method="cvxpy", solver="CLARABEL", check=True).status == "optimal"


def test_clarabel_stays_exact_over_many_hard_instances():
    worst = max(
        np.max(np.abs(ro.project_radii(sp, method="cvxpy").radii - ro.project_radii(sp).radii))
        for sp in (hard_spheres(seed) for seed in range(20))
    )
    assert worst <= 1e-7


def test_uncertified_answer_is_not_called_optimal(monkeypatch):
    """If the polish cannot certify the solver's answer, the status is optimal_inaccurate."""
    import radialopt.projection.backends as backends

    monkeypatch.setattr(backends, "_polish_certified", lambda G, h, z, s: (z, False))
    sol = ro.project_radii(hard_spheres(26), method="cvxpy")
    assert sol.status == "optimal_inaccurate"


# ------------------------------------------------------------------ check="exact"
def _has_gmp():
    try:
        import cdd.gmp  # noqa: F401
    except ImportError:
        return False
    return True


def _rational_bruteforce(A, b):
    """Exact vertices (every n-subset of rows, Fractions) and the restriction ray (1, ..., 1):
    an independent reference for pycddlib's GMP mode."""
    from itertools import combinations

    from radialopt._exact_check import _solve_rational

    n = len(A[0])
    verts = set()
    for S in combinations(range(len(A)), n):
        x = _solve_rational([A[i] for i in S], [b[i] for i in S])
        if x is not None and all(sum(a * v for a, v in zip(row, x, strict=True)) <= bi
                                 for row, bi in zip(A, b, strict=True)):
            verts.add(tuple(x))
    return [list(v) for v in verts], [[1] * n]


@pytest.fixture
def exact_mode():
    """pycddlib's exact mode; skipped only where it is not installed (CI installs it)."""
    if not _has_gmp():
        pytest.skip("pycddlib's exact mode (cdd.gmp) is not installed")


@pytest.mark.parametrize("n", [3, 4])
def test_gmp_generators_equal_rational_bruteforce(exact_mode, n):
    """pycddlib's rational enumeration against every n-subset of rows solved in Fractions."""
    from fractions import Fraction

    from radialopt._exact_check import _exact_generators
    from radialopt.polytope import RestrictionPolytope

    centers = np.random.default_rng(40 + n).uniform(-3, 3, (n, 3))
    P = RestrictionPolytope.from_centers(centers)
    A = [[Fraction(float(a)) for a in row] for row in P.A]
    b = [Fraction(float(v)) for v in P.b]
    verts, rays = _exact_generators(A, b)
    ref_verts, _ = _rational_bruteforce(A, b)
    assert sorted(map(tuple, verts)) == sorted(map(tuple, ref_verts))
    assert len(rays) == 1 and len(set(rays[0])) == 1 and rays[0][0] > 0  # the ray (1, ..., 1)


@pytest.mark.parametrize("n", [3, 4])
def test_exact_check_accepts_every_method(exact_mode, n):
    spheres = infeasible_spheres(np.random.default_rng(30 + n), n)
    for method in ("active_set", "cvxpy", "vertices", "paper"):
        assert ro.project_radii(spheres, method=method, check="exact").status == "optimal"


def test_exact_check_rejects_a_feasible_but_wrong_answer(exact_mode):
    from radialopt.projection import verify_solution_exact

    spheres = infeasible_spheres(np.random.default_rng(33), 3)
    sol = ro.project_radii(spheres)
    moved = sol.radii + 1e-3  # along the ray: still feasible, no longer optimal
    bad = ro.RadialSolution(moved, moved - (sol.radii - sol.displacement), sol.density,
                            "optimal", "active_set", None, 0.0, sol.active_rows)
    with pytest.raises(ro.VerificationError, match="exact"):
        verify_solution_exact(spheres, bad)
    outside = ro.RadialSolution(0.0 * sol.radii, sol.displacement, sol.density, "optimal",
                                "active_set", None, 0.0)
    with pytest.raises(ro.VerificationError, match="violate"):
        verify_solution_exact(spheres, outside)


def test_exact_check_without_gmp_names_the_missing_mode(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "cdd.gmp", None)  # import cdd.gmp now raises ImportError
    spheres = infeasible_spheres(np.random.default_rng(34), 3)
    with pytest.raises(ro.RadialError, match=r"check='exact' needs pycddlib's exact rational.*cdd.gmp"):
        ro.project_radii(spheres, check="exact")


def test_check_argument_is_validated():
    spheres = infeasible_spheres(np.random.default_rng(35), 3)
    with pytest.raises(ro.RadialError, match=r"check must be False, True or 'exact', got"):
        ro.project_radii(spheres, check="rational")


def test_exact_check_with_gmp_on_a_hard_instance(exact_mode):
    spheres = hard_spheres(HARD_SEEDS[0], n=5)
    assert ro.project_radii(spheres, method="cvxpy", check="exact").status == "optimal"


# ------------------------------------------------------------- row generation (many spheres)
@pytest.mark.parametrize("n", [25, 40, 70])
def test_row_generation_equals_the_all_rows_solve(n):
    """Above CONSTRAINT_GENERATION_ROWS rows the active set generates its rows; the answer
    equals the solve on all rows at once and Clarabel's through cvxpy (independent)."""
    from radialopt._ldp import _least_distance_dense
    from radialopt.projection import CONSTRAINT_GENERATION_ROWS, least_distance
    from radialopt.spheres import make_spheres

    rng = np.random.default_rng(500 + n)
    for trial in range(4):
        c = rng.uniform(0, 10, (n, 3))
        x = rng.uniform(2, 8, 3)
        noise = [0.01, 0.05, 0.5, 2.0][trial]
        r = np.abs(np.linalg.norm(c - x, axis=1) + rng.normal(0, noise, n))
        s = rng.uniform(0.005, 0.2, n)
        sol = ro.project_radii(make_spheres(c, r, s))
        ref = ro.project_radii(make_spheres(c, r, s), method="cvxpy")
        assert sol.status == ref.status == "optimal"
        np.testing.assert_allclose(sol.radii, ref.radii, atol=1e-9)
        # the same least-distance problem, whitened: generated rows against all rows
        P = ro.RestrictionPolytope.from_spheres(make_spheres(c, r, s))
        G = P.A * s[None, :]
        h = P.b - P.A @ r
        assert len(h) > CONSTRAINT_GENERATION_ROWS
        z_gen, st_gen = least_distance(G, h)
        z_all, st_all = _least_distance_dense(G, h)
        assert st_gen == st_all == "optimal"
        np.testing.assert_allclose(z_gen, z_all, atol=1e-10)
