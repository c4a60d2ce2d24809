"""estimate_position("ml") in a thin valley, on the numbers of the issue-12 audit of radialopt.

D3: ``estimate_position("ml")`` stopped at its iteration cap in a thin valley and said "ok".
"""

from __future__ import annotations

import numpy as np

import radialopt as ro

# --- D3: ML in the thin valley of a very precise sphere ------------------------------------

def _d3_scene(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """4-6 landmarks, sigma 0.1 m, one sphere 1e5 times more precise (sigma 1e-6 m)."""
    n = int(rng.integers(4, 7))
    c = rng.uniform(-3, 3, (n, 3))
    x = rng.uniform(-3, 3, 3)
    sig = np.full(n, 0.1)
    sig[int(rng.integers(n))] = 1e-6
    r = np.abs(np.linalg.norm(c - x, axis=1) + 3 * sig * rng.standard_normal(n))
    return c, r, sig


def _ml_cost(x, c, r, s) -> float:
    return float(np.sum(((np.linalg.norm(x - c, axis=1) - r) / s) ** 2))


def _valley_reference(c, r, s) -> float:
    """Dense grid over the precise sphere's surface in polar angles, then least squares in
    (theta, phi, rho) about its centre from the 4 best grid points (radialopt not used)."""
    from scipy.optimize import least_squares

    p = int(np.argmin(s))
    th, ph = np.meshgrid(np.linspace(0, np.pi, 61), np.linspace(-np.pi, np.pi, 121), indexing="ij")
    u = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1).reshape(-1, 3)
    d = np.linalg.norm((c[p] + r[p] * u)[:, None] - c[None], axis=2)
    grid_cost = np.sum(((d - r) / s) ** 2, axis=1)

    def fun(q):
        uu = np.array([np.sin(q[0]) * np.cos(q[1]), np.sin(q[0]) * np.sin(q[1]), np.cos(q[0])])
        return (np.linalg.norm(c[p] + (r[p] + q[2]) * uu - c, axis=1) - r) / s

    best = np.inf
    for k in np.argsort(grid_cost)[:4]:
        q0 = [np.arccos(np.clip(u[k, 2], -1, 1)), np.arctan2(u[k, 1], u[k, 0]), 0.0]
        sol = least_squares(fun, q0, xtol=1e-15, ftol=1e-15, gtol=1e-15, x_scale=[1, 1, s[p]])
        best = min(best, 2 * sol.cost)
    return best


def test_d3_ml_reaches_the_optimum_at_sigma_ratio_1e5():
    rng = np.random.default_rng(1205)
    for i in range(100):
        c, r, s = _d3_scene(rng)
        est = ro.estimate_position(ro.make_spheres(c, r, s))
        assert est.status in ro.POSITION_STATUSES
        ref = _valley_reference(c, r, s)
        got = _ml_cost(est.position, c, r, s)
        assert got <= ref * (1 + 1e-6) + 1e-9, (i, got, ref, est.status)


def test_ml_at_its_cap_does_not_say_ok():
    rng = np.random.default_rng(7)
    c, r, s = _d3_scene(rng)
    opts = ro.EstimatorOptions(lm_max_iter=1, polish_max_nfev=1, polish_candidates=1)
    est = ro.estimate_position(ro.make_spheres(c, r, s), options=opts)
    assert est.status == "not_converged"
    assert est.status in ro.POSITION_STATUSES


def test_gradient_at_its_cap_does_not_say_ok():
    rng = np.random.default_rng(7)
    c, r, s = _d3_scene(rng)
    opts = ro.EstimatorOptions(gradient_max_iter=3)
    est = ro.estimate_position(ro.make_spheres(c, r, s), method="gradient", options=opts)
    assert est.status == "not_converged"
