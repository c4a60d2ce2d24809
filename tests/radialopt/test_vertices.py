"""Vertex enumeration (brute force vs double description vs pycddlib) and V-form projection."""

from __future__ import annotations

import itertools

import cdd
import cvxpy as cp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog
from scipy.spatial.distance import cdist

from radialopt.errors import RadialError
from radialopt.polytope import RestrictionPolytope
from radialopt.vertices import (
    VERTEX_TOLERANCES,
    VertexEnumeration,
    certify_projection,
    enumerate_vertices,
    project_vform,
)

#: One tolerance table for the comparisons in this file.
TOL = {
    "vertex": 1e-7,  # Hausdorff distance between vertex sets (metres)
    "ray": 1e-9,  # between unit rays
    "projection": 1e-7,  # V-form projection vs an independent solver (metres)
    "certificate": 1e-7,  # certify_projection tolerance
    "projection_near_degenerate": 1e-5,  # V-form of a nearly degenerate P (see the test)
    "clarabel": 1e-4,  # raw Clarabel, tight tolerances (docs/design.md#solver-tolerances)
}

# ---------------------------------------------------------------------------------------------
# strategies: valid centre sets built directly


def _seeded(seed: int, n: int, scale: float = 5.0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-scale, scale, size=(n, 3))


@st.composite
def general_centers(draw, n: int) -> np.ndarray:
    """Centres in general position (continuous random coordinates from a drawn seed)."""
    return _seeded(draw(st.integers(0, 2**32 - 1)), n)


@st.composite
def collinear_centers(draw, n: int) -> np.ndarray:
    """Centres on one line: distinct integer positions along a random direction."""
    steps = draw(st.lists(st.integers(-6, 6), min_size=n, max_size=n, unique=True))
    direction = np.array([draw(st.floats(-1, 1)) for _ in range(3)]) + np.array([1.5, 0.0, 0.0])
    origin = np.array([draw(st.floats(-3, 3)) for _ in range(3)])
    return origin + np.array(steps, dtype=float)[:, None] * direction


@st.composite
def one_height_centers(draw, n: int) -> np.ndarray:
    """Centres at one height (door handles): distinct (x, y) on a 0.25 m grid, z fixed."""
    cells = draw(st.lists(st.integers(0, 20 * 20 - 1), min_size=n, max_size=n, unique=True))
    xy = 0.25 * np.stack(np.divmod(np.array(cells), 20), axis=1).astype(float) - 2.5
    z = draw(st.floats(-2, 2))
    return np.column_stack([xy, np.full(n, z)])


@st.composite
def integer_centers(draw, n: int) -> np.ndarray:
    """Distinct integer centres in {-2..2}^3: many equal distances (ties)."""
    cells = draw(st.lists(st.integers(0, 124), min_size=n, max_size=n, unique=True))
    return np.stack(np.unravel_index(np.array(cells), (5, 5, 5)), axis=1).astype(float) - 2.0


@st.composite
def near_collinear_centers(draw, n: int) -> np.ndarray:
    """Nearly collinear centres (triangle inequalities almost tight: nearly tangent spheres)."""
    line = draw(collinear_centers(n))
    eps = 10.0 ** draw(st.floats(-9, -2))
    offsets = np.array([[draw(st.floats(-1, 1)) for _ in range(3)] for _ in range(n)])
    return line + eps * offsets


@st.composite
def any_centers(draw, n: int) -> np.ndarray:
    return draw(
        st.one_of(
            general_centers(n),
            collinear_centers(n),
            one_height_centers(n),
            integer_centers(n),
            near_collinear_centers(n),
        )
    )


# ---------------------------------------------------------------------------------------------
# helpers


def hausdorff(X: np.ndarray, Y: np.ndarray) -> float:
    if X.shape[0] == 0 or Y.shape[0] == 0:
        return 0.0 if X.shape[0] == Y.shape[0] else np.inf
    D = cdist(X, Y)
    return float(max(D.min(axis=0).max(), D.min(axis=1).max()))


def cdd_generators(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and unit rays from pycddlib (float mode), the independent reference."""
    mat = cdd.matrix_from_array(np.hstack([b[:, None], -A]).tolist(), rep_type=cdd.RepType.INEQUALITY)
    gen = np.array(cdd.copy_generators(cdd.polyhedron_from_matrix(mat)).array, dtype=float)
    is_vertex = np.abs(gen[:, 0] - 1.0) < 1e-9
    is_ray = np.abs(gen[:, 0]) < 1e-9
    assert np.all(is_vertex | is_ray)
    rays = gen[is_ray, 1:]
    return gen[is_vertex, 1:], rays / np.linalg.norm(rays, axis=1)[:, None]


def assert_same_generators(E1: VertexEnumeration, E2: VertexEnumeration | tuple, counts: bool = True) -> None:
    V2, R2 = (E2.vertices, E2.rays) if isinstance(E2, VertexEnumeration) else E2
    if counts:
        assert E1.vertices.shape == V2.shape
        assert E1.rays.shape == R2.shape
    assert hausdorff(E1.vertices, V2) <= TOL["vertex"]
    assert hausdorff(E1.rays, R2) <= TOL["ray"]


def assert_valid_enumeration(P: RestrictionPolytope, E: VertexEnumeration) -> None:
    n = P.dim
    scale = max(1.0, float(np.abs(P.b).max()))
    slack = P.b[None, :] - E.vertices @ P.A.T
    assert np.all(slack >= -1e-9 * scale)
    tight = np.abs(slack) <= VERTEX_TOLERANCES.active * scale
    np.testing.assert_array_equal(E.vertex_active, tight)
    assert np.all(tight.sum(axis=1) >= n)
    for row in tight:
        assert np.linalg.matrix_rank(P.A[row]) == n
    # vertices are distinct and sorted lexicographically
    merge = VERTEX_TOLERANCES.merge * scale
    assert np.all(cdist(E.vertices, E.vertices)[np.triu_indices(len(E.vertices), 1)] > merge)
    order = np.lexsort(E.vertices.T[::-1])
    np.testing.assert_array_equal(order, np.arange(len(E.vertices)))
    # the only ray of the restriction polyhedron
    np.testing.assert_allclose(E.rays, np.full((1, n), 1.0 / np.sqrt(n)), atol=1e-12)


def assert_complete(P: RestrictionPolytope, E: VertexEnumeration, rng: np.random.Generator) -> None:
    """conv(V) + cone(R) = P: for random bounded objectives the LP optimum over the H-form
    (HiGHS) equals the best vertex; the optimal point of every LP is a combination of them."""
    n = P.dim
    for _ in range(10):
        c = rng.standard_normal(n) + 2.0 * np.ones(n)  # c . ray > 0 keeps the LP bounded
        if c @ E.rays[0] <= 0.1:
            c = c + (0.2 - c @ E.rays[0]) * E.rays[0] * np.sqrt(n)
        res = linprog(c, A_ub=P.A, b_ub=P.b, bounds=[(None, None)] * n, method="highs")
        assert res.status == 0
        best = float(np.min(E.vertices @ c))
        assert best == pytest.approx(res.fun, abs=1e-7 * max(1.0, abs(res.fun)))


# ---------------------------------------------------------------------------------------------
# enumeration: brute force vs double description vs pycddlib


@pytest.mark.parametrize("n", [3, 4, 5])
@given(data=st.data())
@settings(max_examples=15)
def test_bruteforce_equals_double_description(n: int, data) -> None:
    """General position: the same vertex and ray sets, counts included."""
    P = RestrictionPolytope.from_centers(data.draw(general_centers(n)))
    brute = enumerate_vertices(P, method="bruteforce")
    dd = enumerate_vertices(P, method="double_description")
    assert brute.method == "bruteforce" and dd.method == "double_description"
    assert_same_generators(brute, dd)
    assert_valid_enumeration(P, brute)
    assert_valid_enumeration(P, dd)


@pytest.mark.parametrize("n", [3, 4, 5])
@given(data=st.data())
@settings(max_examples=25)
def test_bruteforce_near_double_description_on_degenerate_inputs(n: int, data) -> None:
    """Degenerate inputs: collinear centres, one height, integer ties, nearly collinear.

    In floating point a degenerate vertex splits into a cluster of vertices (by ~1e-16 for
    exactly degenerate centres, by ~eps^2 for centres eps off a line); where the split is
    near the tolerances the two methods may resolve a cluster differently, never by more than
    its size: the sets agree in Hausdorff distance, not necessarily in count."""
    strategy = st.one_of(collinear_centers(n), one_height_centers(n), integer_centers(n),
                         near_collinear_centers(n))
    P = RestrictionPolytope.from_centers(data.draw(strategy))
    brute = enumerate_vertices(P, method="bruteforce")
    dd = enumerate_vertices(P, method="double_description")
    assert_same_generators(brute, dd, counts=False)
    assert_valid_enumeration(P, brute)
    assert_valid_enumeration(P, dd)


@pytest.mark.parametrize("strategy", [collinear_centers, one_height_centers, integer_centers,
                                      near_collinear_centers])
@given(data=st.data())
@settings(max_examples=10)
def test_degenerate_inputs_are_complete(strategy, data) -> None:
    """pycddlib's float mode is unreliable here, so completeness is checked against LPs over the
    H-form (and, below, against pycddlib's exact mode)."""
    n = data.draw(st.integers(3, 6))
    P = RestrictionPolytope.from_centers(data.draw(strategy(n)))
    E = enumerate_vertices(P, method="double_description")
    assert_valid_enumeration(P, E)
    assert_complete(P, E, np.random.default_rng(data.draw(st.integers(0, 2**32 - 1))))


def exact_generators(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and unit rays of the float polyhedron in exact rational arithmetic (cdd.gmp)."""
    from fractions import Fraction

    gmp = pytest.importorskip("cdd.gmp", reason="pycddlib's exact mode (cdd.gmp) is not installed")
    rows = [[Fraction(float(bi))] + [-Fraction(float(a)) for a in row] for row, bi in zip(A, b, strict=True)]
    gen = gmp.copy_generators(gmp.polyhedron_from_matrix(
        gmp.matrix_from_array(rows, rep_type=cdd.RepType.INEQUALITY)))
    verts = [[float(Fraction(v) / Fraction(r[0])) for v in r[1:]] for r in gen.array if Fraction(r[0]) != 0]
    rays = np.array([[float(v) for v in r[1:]] for r in gen.array if Fraction(r[0]) == 0])
    return np.array(verts), rays / np.linalg.norm(rays, axis=1)[:, None]


@pytest.mark.parametrize("strategy", [collinear_centers, one_height_centers, integer_centers])
@given(data=st.data())
@settings(max_examples=8)
def test_degenerate_inputs_match_exact_enumeration(strategy, data) -> None:
    """Exactly degenerate centre sets: double description equals pycddlib's rational-arithmetic
    enumeration of the same (float) polyhedron, vertex for vertex."""
    n = data.draw(st.integers(3, 5))
    P = RestrictionPolytope.from_centers(data.draw(strategy(n)))
    E = enumerate_vertices(P, method="double_description")
    V, R = exact_generators(P.A, P.b)
    scale = max(1.0, float(np.abs(P.b).max()))
    # ties within the merge tolerance collapse to one vertex in floating point, never in exact mode
    assert hausdorff(E.vertices, V) <= TOL["vertex"] * scale
    assert hausdorff(E.rays, R) <= TOL["ray"]


@pytest.mark.parametrize(
    ("n", "methods"),
    [
        (3, ("bruteforce", "double_description")),
        (4, ("bruteforce", "double_description")),
        (5, ("bruteforce", "double_description")),
        (6, ("double_description",)),  # brute force would need C(45, 6) = 8.1e6 subsets
    ],
)
@given(data=st.data())
@settings(max_examples=10)
def test_matches_pycddlib_in_general_position(n: int, methods: tuple[str, ...], data) -> None:
    P = RestrictionPolytope.from_centers(data.draw(general_centers(n)))
    reference = cdd_generators(P.A, P.b)
    for method in methods:
        assert_same_generators(enumerate_vertices(P, method=method), reference)


@pytest.mark.parametrize(("n", "count"), [(3, 7), (4, 36), (5, 181), (6, 838)])
@given(data=st.data())
@settings(max_examples=5)
def test_vertex_counts_in_general_position(n: int, count: int, data) -> None:
    E = enumerate_vertices(RestrictionPolytope.from_centers(data.draw(general_centers(n))))
    assert E.vertices.shape == (count, n)
    assert E.rays.shape == (1, n)


def test_seven_spheres_match_pycddlib() -> None:
    P = RestrictionPolytope.from_centers(_seeded(11, 7))
    assert_same_generators(enumerate_vertices(P), cdd_generators(P.A, P.b))


def test_auto_picks_the_fast_method() -> None:
    assert enumerate_vertices(RestrictionPolytope.from_centers(_seeded(0, 4))).method == "bruteforce"
    assert enumerate_vertices(RestrictionPolytope.from_centers(_seeded(0, 6))).method == "double_description"


# ---------------------------------------------------------------------------------------------
# general polyhedra with answers known by construction


@pytest.mark.parametrize("method", ["bruteforce", "double_description"])
def test_cube_is_bounded_with_eight_vertices(method: str) -> None:
    A = np.vstack([np.eye(3), -np.eye(3)])
    b = np.array([1.0, 2.0, 3.0, 0.0, 0.0, 0.0])  # box [0,1] x [0,2] x [0,3]
    E = enumerate_vertices((A, b), method=method)
    expected = np.array(list(itertools.product([0.0, 1.0], [0.0, 2.0], [0.0, 3.0])))
    np.testing.assert_allclose(E.vertices, expected, atol=1e-12)
    assert E.rays.shape == (0, 3)
    assert np.all(E.vertex_active.sum(axis=1) == 3)


@pytest.mark.parametrize("method", ["bruteforce", "double_description"])
def test_degenerate_pyramid_apex(method: str) -> None:
    """Square pyramid: the apex lies on four facets (degenerate vertex)."""
    A = np.array([[0, 0, -1.0], [1, 0, 1], [-1, 0, 1], [0, 1, 1], [0, -1, 1]])
    b = np.array([0.0, 1, 1, 1, 1])
    E = enumerate_vertices((A, b), method=method)
    expected = np.array([[-1, -1, 0], [-1, 1, 0], [0, 0, 1], [1, -1, 0], [1, 1, 0.0]])
    np.testing.assert_allclose(E.vertices, expected, atol=1e-12)
    np.testing.assert_array_equal(E.vertex_active[2], [False, True, True, True, True])


@pytest.mark.parametrize("method", ["bruteforce", "double_description"])
def test_orthant_has_one_vertex_and_two_rays(method: str) -> None:
    A = -np.eye(2)
    b = np.array([-1.0, 2.0])  # x >= 1, y >= -2
    E = enumerate_vertices((A, b), method=method)
    np.testing.assert_allclose(E.vertices, [[1.0, -2.0]], atol=1e-12)
    np.testing.assert_allclose(E.rays, [[0.0, 1.0], [1.0, 0.0]], atol=1e-12)


@pytest.mark.parametrize("method", ["bruteforce", "double_description"])
def test_interval_in_one_dimension(method: str) -> None:
    E = enumerate_vertices((np.array([[2.0], [-1.0], [1.0]]), np.array([4.0, 1.0, 5.0])), method=method)
    np.testing.assert_allclose(E.vertices, [[-1.0], [2.0]], atol=1e-12)
    assert E.rays.shape == (0, 1)


@pytest.mark.parametrize("method", ["bruteforce", "double_description"])
def test_empty_polyhedron(method: str) -> None:
    A = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
    b = np.array([0.0, -1.0, 1.0, 1.0])  # x <= 0 and x >= 1
    E = enumerate_vertices((A, b), method=method)
    assert E.vertices.shape == (0, 2) and E.rays.shape == (0, 2)


# ---------------------------------------------------------------------------------------------
# errors


def test_bad_inputs_raise_specific_errors() -> None:
    A = np.eye(2)
    with pytest.raises(RadialError, match="b must have shape"):
        enumerate_vertices((A, np.ones(3)))
    with pytest.raises(RadialError, match="A must have shape"):
        enumerate_vertices((np.ones(3), np.ones(3)))
    with pytest.raises(RadialError, match="polytope must be a RestrictionPolytope or a pair"):
        enumerate_vertices("not a polytope")
    with pytest.raises(RadialError, match=r"polytope.A\[0, 1\] must be finite, got nan"):
        enumerate_vertices((np.array([[1.0, np.nan], [0, 1]]), np.ones(2)))
    with pytest.raises(RadialError, match="contains a line"):
        enumerate_vertices((np.array([[1.0, 0.0], [-1.0, 0.0]]), np.ones(2)))
    with pytest.raises(RadialError, match=r"unknown method 'lrs'; choose one.*double_description"):
        enumerate_vertices((A, np.ones(2)), method="lrs")
    big = RestrictionPolytope.from_centers(_seeded(0, 8))
    # a plain (A, b) pair is not held to MAX_VERTEX_SPHERES
    with pytest.raises(RadialError, match=r"brute force needs C\(84, 8\) = \d+ subsets"):
        enumerate_vertices((big.A, big.b), method="bruteforce")
    with pytest.raises(RadialError, match="8 spheres.*MAX_VERTEX_SPHERES = 7"):
        enumerate_vertices(big, method="bruteforce")


def test_projection_input_errors() -> None:
    P = RestrictionPolytope.from_centers(_seeded(1, 3))
    E = enumerate_vertices(P)
    with pytest.raises(RadialError, match=r"target must have shape \(3,\)"):
        project_vform(E, np.ones(4), np.ones(3))
    with pytest.raises(RadialError):
        project_vform(E, np.ones(3), np.array([1.0, 0.0, 1.0]))
    with pytest.raises(RadialError, match=r"point\[0\] must be finite, got inf"):
        certify_projection(E, P, np.ones(3), np.ones(3), np.array([np.inf, 0, 0]))


# ---------------------------------------------------------------------------------------------
# V-form projection and certificate


@st.composite
def projection_problems(draw, min_n: int = 3, max_n: int = 6):
    """Centres (general position or degenerate), a target of measured radii and sigmas.

    Returns ``(polytope, target, sigmas)``.  Nearly collinear centres are left out: see
    :func:`test_vform_projection_nearly_degenerate`.
    """
    n = draw(st.integers(min_n, max_n))
    centers = draw(st.one_of(general_centers(n), collinear_centers(n), one_height_centers(n),
                             integer_centers(n)))
    target = np.array([draw(st.floats(0.0, 10.0)) for _ in range(n)])
    sigmas = np.array([draw(st.floats(1e-3, 2.0)) for _ in range(n)])
    return RestrictionPolytope.from_centers(centers), target, sigmas


def hform_projection(P: RestrictionPolytope, target: np.ndarray, sigmas: np.ndarray) -> np.ndarray:
    """Independent: Clarabel on the whitened H-form QP (docs/design.md#m4), tight tolerances."""
    z = cp.Variable(P.dim)
    prob = cp.Problem(cp.Minimize(cp.sum_squares(z)), [(P.A * sigmas) @ z <= P.b - P.A @ target])
    try:
        prob.solve(solver="CLARABEL", tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12, tol_ktratio=1e-10)
    except cp.error.SolverError:  # 1e-12 is beyond reach on a few degenerate instances
        prob.solve(solver="CLARABEL", tol_gap_abs=1e-9, tol_gap_rel=1e-9, tol_feas=1e-9)
    assert prob.status in ("optimal", "optimal_inaccurate")
    return target + sigmas * z.value


def faces_hform_projection(P: RestrictionPolytope, target: np.ndarray, sigmas: np.ndarray) -> np.ndarray:
    """Independent and exact (slow, obvious): the projection is the minimum-norm point of the
    affine hull of its active face, for some linearly independent set T of <= n active rows.
    Clarabel's answer (within ~1e-6) narrows the rows to the near-active ones; every subset
    T of those gives a candidate ``z = pinv(G_T) h_T``; the best feasible candidate is the
    optimum (every feasible candidate is in P, and the optimum is among them)."""
    x0 = hform_projection(P, target, sigmas)
    scale = max(1.0, float(np.abs(P.b).max()))
    near = np.flatnonzero(P.slack(x0) <= 1e-4 * scale)
    G = P.A * sigmas  # whitened: G z <= h, z = (x - target) / sigmas
    h = P.b - P.A @ target
    best, best_val = None, np.inf
    for size in range(0, min(P.dim, near.size) + 1):
        if size == 0:
            z = np.zeros((1, P.dim))
        else:
            subsets = np.array(list(itertools.combinations(near, size)), dtype=int)
            z = np.einsum("cij,cj->ci", np.linalg.pinv(G[subsets]), h[subsets])
        feasible = np.all(z @ G.T <= h + 1e-9 * scale, axis=1)
        if feasible.any():
            values = np.sum(z[feasible] ** 2, axis=1)
            i = int(np.argmin(values))
            if values[i] < best_val:
                best, best_val = z[feasible][i], float(values[i])
    assert best is not None
    return target + sigmas * best


def vform_objective_cvxpy(E: VertexEnumeration, target: np.ndarray, sigmas: np.ndarray) -> float:
    """Independent: Clarabel on the same V-form (lam in the simplex, mu >= 0), optimal value.

    The V-form has many redundant weights and an interior-point method reaches only ~1e-5 m
    in the point there, so only the optimal value is compared."""
    lam = cp.Variable(E.vertices.shape[0], nonneg=True)
    mu = cp.Variable(E.rays.shape[0], nonneg=True)
    W = ((E.vertices - target) / sigmas).T
    D = (E.rays / sigmas).T
    prob = cp.Problem(cp.Minimize(cp.sum_squares(W @ lam + D @ mu)), [cp.sum(lam) == 1])
    prob.solve(solver="CLARABEL", tol_gap_abs=1e-9, tol_gap_rel=1e-9, tol_feas=1e-9)
    assert prob.status == "optimal"
    return float(prob.value)


def faces_projection(E: VertexEnumeration, target: np.ndarray, sigmas: np.ndarray) -> np.ndarray:
    """Slow obvious reference: for every affinely independent generator subset of size <= n+1
    (with a vertex w0), minimise ``|w0 + M c|`` over the affine hull (lstsq on M, no normal
    equations); keep minimisers with non-negative weights; return the best."""
    W = (E.vertices - target) / sigmas
    D = E.rays / sigmas
    gens = np.vstack([W, D])
    k, n = W.shape
    best, best_val = None, np.inf
    for size in range(1, n + 2):
        for subset in itertools.combinations(range(gens.shape[0]), size):
            s = np.array(subset)
            if s[0] >= k:  # needs a vertex; s is sorted, so s[0] is one if any is
                continue
            w0 = gens[s[0]]
            M = np.column_stack([gens[i] - w0 if i < k else gens[i] for i in s[1:]]) if size > 1 else (
                np.zeros((n, 0))
            )
            if M.shape[1] and np.linalg.matrix_rank(M) < M.shape[1]:
                continue
            c = np.linalg.lstsq(M, -w0, rcond=None)[0] if M.shape[1] else np.zeros(0)
            is_point = s[1:] < k
            weights = np.concatenate([[1.0 - c[is_point].sum()], c])
            if np.any(weights < -1e-12):
                continue
            z = w0 + M @ c
            if z @ z < best_val:
                best, best_val = z, float(z @ z)
    return target + sigmas * best


@given(problem=projection_problems())
@settings(max_examples=30)
def test_vform_projection_matches_clarabel(problem) -> None:
    P, target, sigmas = problem
    E = enumerate_vertices(P)
    point, weights = project_vform(E, target, sigmas)
    k = E.vertices.shape[0]
    assert weights.shape == (k + E.rays.shape[0],)
    assert np.all(weights >= 0) and weights[:k].sum() == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(E.vertices.T @ weights[:k] + E.rays.T @ weights[k:], point, atol=1e-9)
    np.testing.assert_allclose(point, faces_hform_projection(P, target, sigmas), atol=TOL["projection"])
    # raw Clarabel drifts by up to ~1e-6 (degenerate active sets, sigma ratios of 1e3)
    np.testing.assert_allclose(point, hform_projection(P, target, sigmas), atol=TOL["clarabel"])
    objective = float(np.sum(((point - target) / sigmas) ** 2))
    assert objective == pytest.approx(vform_objective_cvxpy(E, target, sigmas), rel=1e-6, abs=1e-9)
    ok, residual, message = certify_projection(E, P, target, sigmas, point, tol=TOL["certificate"])
    assert ok, message
    assert residual <= TOL["certificate"]


@given(problem=projection_problems(max_n=3))
@settings(max_examples=20)
def test_vform_projection_matches_search_over_faces(problem) -> None:
    P, target, sigmas = problem
    E = enumerate_vertices(P)
    point, _ = project_vform(E, target, sigmas)
    np.testing.assert_allclose(point, faces_projection(E, target, sigmas), atol=1e-8)


@given(data=st.data())
@settings(max_examples=20)
def test_vform_projection_nearly_degenerate(data) -> None:
    """Nearly collinear centres: vertex clusters of size ~eps^2 are resolved only up to the
    enumeration tolerances (1e-9 relative), and the V-form set differs from P by that much;
    the projection then agrees with the exact one to ~1e-6 (not 1e-7), and it passes the
    certificate on its own generators."""
    n = data.draw(st.integers(3, 5))
    P = RestrictionPolytope.from_centers(data.draw(near_collinear_centers(n)))
    target = np.array([data.draw(st.floats(0.0, 10.0)) for _ in range(n)])
    sigmas = np.array([data.draw(st.floats(1e-2, 2.0)) for _ in range(n)])
    for method in ("bruteforce", "double_description"):
        E = enumerate_vertices(P, method=method)
        point, _ = project_vform(E, target, sigmas)
        ok, _, message = certify_projection(E, P, target, sigmas, point, tol=TOL["certificate"])
        assert ok, message
        np.testing.assert_allclose(point, faces_hform_projection(P, target, sigmas),
                                   atol=TOL["projection_near_degenerate"])


def test_target_inside_is_its_own_projection() -> None:
    centers = _seeded(3, 4)
    P = RestrictionPolytope.from_centers(centers)
    inside = np.linalg.norm(centers - np.array([0.3, -0.2, 0.1]), axis=1)  # radii that meet
    E = enumerate_vertices(P)
    point, _ = project_vform(E, inside, np.full(4, 0.1))
    np.testing.assert_allclose(point, inside, atol=1e-9)


@given(problem=projection_problems(), data=st.data())
@settings(max_examples=30)
def test_certificate_rejects_wrong_points(problem, data) -> None:
    P, target, sigmas = problem
    E = enumerate_vertices(P)
    point = faces_hform_projection(P, target, sigmas)
    ok, _, message = certify_projection(E, P, target, sigmas, point, tol=1e-6)
    assert ok, message
    if not np.any(P.slack(target) < -1e-6):  # target inside: nothing else to reject
        return
    # an infeasible point: step outward through the most violated row of the target
    row = int(np.argmin(P.slack(target)))
    outside = point + 1e-3 * P.A[row] + (P.slack(point)[row]) * P.A[row]
    ok, residual, message = certify_projection(E, P, target, sigmas, outside, tol=1e-6)
    assert not ok and residual > 1e-6 and "infeasible" in message
    # feasible but not closest: a vertex other than the projection, or a point on the way to it
    far = int(np.argmax(np.linalg.norm((E.vertices - point) / sigmas, axis=1)))
    t = data.draw(st.floats(0.05, 1.0))
    between = point + t * (E.vertices[far] - point)
    assert P.contains(between, tol=1e-9)
    ok, _, message = certify_projection(E, P, target, sigmas, between, tol=1e-6)
    assert not ok and "not optimal" in message
