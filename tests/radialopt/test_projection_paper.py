"""project_radii(method="paper") on the numbers of the issue-12 audit of radialopt.

D1: ``project_radii(method="paper")`` enumerated every flat of all rows (n = 8: > 30 s).
D2: the paper's eq. 17 also projected onto rows the measured radii satisfy (cost 25.7 where
the optimum is 0.0196).  sigma >= 1e10: "paper" said "optimal" with radii 0.7 m infeasible.
"""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest

import radialopt as ro
from tests.problems import infeasible_spheres

D2_CENTERS = np.array([[4.0, 3, 0], [2, 1, 0], [2, 3, 2]])
D2_RADII = np.array([2.0, 5, 5])


def pair_constraints(centers: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``A r <= b`` written out independently of radialopt: for each pair, r_i + r_j >= d,
    |r_i - r_j| <= d."""
    rows, rhs = [], []
    n = len(centers)
    for i in range(n):
        for j in range(i + 1, n):
            d = float(np.linalg.norm(centers[i] - centers[j]))
            for a, bb in (((-1, -1), -d), ((-1, 1), d), ((1, -1), d)):
                row = np.zeros(n)
                row[i], row[j] = a
                rows.append(row)
                rhs.append(bb)
    return np.array(rows), np.array(rhs)


def reference_cost(centers, radii, sigmas) -> float:
    """min sum(((x - r)/sigma)^2) s.t. the pair constraints, by cvxpy (Clarabel) directly."""
    A, b = pair_constraints(centers)
    x = cp.Variable(len(radii))
    prob = cp.Problem(cp.Minimize(cp.sum_squares(cp.multiply(1 / sigmas, x - radii))), [A @ x <= b])
    prob.solve(solver="CLARABEL")
    return float(prob.value)


def brute_force_cost(centers, radii, sigmas) -> float:
    """The same optimum by enumerating every set of <= n active rows (KKT by brute force)."""
    from itertools import combinations

    A, b = pair_constraints(centers)
    S = np.diag(sigmas**2)
    best = np.inf
    for k in range(len(radii) + 1):
        for T in combinations(range(len(b)), k):
            T = list(T)
            if k:
                M = A[T] @ S @ A[T].T
                if abs(np.linalg.det(M)) < 1e-12:
                    continue
                y = np.linalg.solve(M, b[T] - A[T] @ radii)
                x = radii + S @ A[T].T @ y
            else:
                x = radii.copy()
            if np.all(A @ x <= b + 1e-9):
                best = min(best, float(np.sum(((x - radii) / sigmas) ** 2)))
    return best


def cost(spheres, radii) -> float:
    r = np.array([s.radius for s in spheres])
    s = np.array([s.sigma for s in spheres])
    return float(np.sum(((np.asarray(radii) - r) / s) ** 2))


def test_d2_paper_uses_violated_hyperplanes_only():
    spheres = ro.make_spheres(D2_CENTERS, D2_RADII, 1.0)
    sig = np.ones(3)
    ref = reference_cost(D2_CENTERS, D2_RADII, sig)
    assert ref == pytest.approx(0.0196, abs=1e-4)
    assert brute_force_cost(D2_CENTERS, D2_RADII, sig) == pytest.approx(ref, rel=1e-6)
    for method in ("active_set", "paper"):
        sol = ro.project_radii(spheres, method=method)
        assert cost(spheres, sol.radii) == pytest.approx(ref, rel=1e-6), method
        assert sol.status == "optimal"
    paper = ro.project_radii(spheres, method="paper")
    assert cost(spheres, paper.radii) < 1.0  # the audit's wrong answer cost 25.7


def test_paper_violated_rule_against_the_optimum_on_100_instances():
    """What is true of the violated-only rule: always feasible and never below the optimum;
    "optimal" exactly when it equals the optimum (KKT-certified); otherwise "optimal_inaccurate".
    At n = 3 (the audit's instances) it was the optimum every time."""
    rng = np.random.default_rng(12)
    equal = {3: 0, 5: 0}
    for n in (3, 5):
        for _ in range(50):
            spheres = infeasible_spheres(rng, n)
            centers = np.array([s.center for s in spheres])
            radii = np.array([s.radius for s in spheres])
            sig = np.array([s.sigma for s in spheres])
            ref = brute_force_cost(centers, radii, sig) if n == 3 else reference_cost(centers, radii, sig)
            exact = ro.project_radii(spheres)
            assert cost(spheres, exact.radii) == pytest.approx(ref, rel=1e-6, abs=1e-10)
            paper = ro.project_radii(spheres, method="paper")
            A, b = pair_constraints(centers)
            assert np.all(A @ paper.radii <= b + 1e-9 * max(1.0, np.abs(b).max()))
            c = cost(spheres, paper.radii)
            assert c >= ref * (1 - 1e-6) - 1e-10
            same = c <= cost(spheres, exact.radii) * (1 + 1e-9) + 1e-12
            equal[n] += same
            assert paper.status == ("optimal" if same else "optimal_inaccurate")
    assert equal[3] == 50
    assert equal[5] >= 40


def test_d1_paper_at_eight_spheres_returns():
    rng = np.random.default_rng(8)
    for _ in range(5):
        spheres = infeasible_spheres(rng, 8)
        sol = ro.project_radii(spheres, method="paper")
        assert sol.status in ("optimal", "optimal_inaccurate")
        assert cost(spheres, sol.radii) >= cost(spheres, ro.project_radii(spheres).radii) - 1e-9


def test_d1_paper_beyond_its_budget_raises_naming_n():
    rng = np.random.default_rng(3)
    spheres = ro.make_spheres(rng.uniform(-3, 3, (8, 3)), np.full(8, 0.01), 1.0)
    with pytest.raises(ro.RadialError, match="n = 8"):
        ro.project_radii(spheres, method="paper")


@pytest.mark.parametrize("sigma", [1e10, 1e12, 1e-6])
def test_huge_sigma_optimal_means_feasible(sigma):
    spheres = ro.make_spheres(D2_CENTERS, D2_RADII, sigma)
    A, b = pair_constraints(D2_CENTERS)
    for method in ro.METHODS:
        try:
            sol = ro.project_radii(spheres, method=method)
        except ro.RadialError:
            continue
        if sol.status == "optimal":
            assert np.max(A @ sol.radii - b) <= 1e-9 * 5, (method, sol.radii)
            assert cost(spheres, sol.radii) == pytest.approx(0.0196 / sigma**2, rel=1e-2), method
