"""Certificates of global optimality of the ML position.

The reference is an independent brute force: batched Levenberg-Marquardt from a 6^3 grid of
starts (216 >= 200) over [-3, 13]^3 for every scene, Newton-polished; no radialopt code.
"""

import numpy as np
import pytest

import radialopt as ro
from radialopt.certificates import closed_form_multiplier


def scene_batch(rng, count, n, coplanar=False):
    """``count`` random scenes with ``n`` landmarks in a 10 m room.

    sigma = rho^2 / depth_factor, depth_factor log-uniform in [100, 1000] (eq. 6).  With
    ``coplanar`` the landmarks lie within a few cm of a horizontal plane and the robot within
    0.6 m of it (mirror local minima)."""
    c = rng.uniform(0.0, 10.0, (count, n, 3))
    x = rng.uniform(0.5, 9.5, (count, 3))
    if coplanar:
        h = rng.uniform(1.0, 3.0, count)
        c[:, :, 2] = h[:, None] + rng.normal(0.0, 0.05, (count, n))
        x[:, 2] = h + rng.uniform(-0.6, 0.6, count)
    rho = np.linalg.norm(c - x[:, None], axis=2)
    s = rho**2 / np.exp(rng.uniform(np.log(100.0), np.log(1000.0), (count, n)))
    r = np.abs(rho + s * rng.standard_normal((count, n)))
    return c, r, s, x


def cost_grad_hess(x, c, r, s):
    """Cost (m,), gradient (m, 3), Hessian (m, 3, 3) of sum ((|x - c| - r) / s)^2; x (m, 3),
    c (m, n, 3), r and s (m, n)."""
    diff = x[:, None, :] - c
    d = np.maximum(np.linalg.norm(diff, axis=2), 1e-300)
    w = 1.0 / s**2
    res = d - r
    u = diff / d[..., None]
    f = np.sum(w * res**2, axis=1)
    g = 2.0 * np.einsum("mn,mnk->mk", w * res, u)
    rho = r / d
    H = 2.0 * (np.sum(w * (1 - rho), axis=1)[:, None, None] * np.eye(3)
               + np.einsum("mn,mni,mnj->mij", w * rho, u, u))
    return f, g, H


def local_minima(c, r, s, grid=6, iters=30, extra=None):
    """Multi-start minimisation of every scene ``(S, n, ...)`` from a ``grid^3`` lattice over
    [-3, 13]^3.  Returns per scene a list of (point, cost) of distinct local minima (gradient
    near zero, Hessian positive definite), cheapest first."""
    S, n = r.shape
    g1 = np.linspace(-3.0, 13.0, grid)
    starts = np.stack(np.meshgrid(g1, g1, g1, indexing="ij"), -1).reshape(-1, 3)
    x = np.broadcast_to(starts, (S,) + starts.shape)
    if extra is not None:  # (S, e, 3) scene-specific starts
        x = np.concatenate([x, extra], axis=1)
    K = x.shape[1]
    x = x.reshape(-1, 3).copy()
    C, R, SG = np.repeat(c, K, axis=0), np.repeat(r, K, axis=0), np.repeat(s, K, axis=0)
    mu = np.full(len(x), 1e-3)
    f, g, H = cost_grad_hess(x, C, R, SG)
    eye = np.eye(3)
    for _ in range(iters):
        scale = np.trace(H, axis1=1, axis2=2)[:, None, None] / 3 + 1e-12
        ev = np.linalg.eigvalsh(H)[:, 0]
        diff = x[:, None, :] - C
        d = np.maximum(np.linalg.norm(diff, axis=2), 1e-300)
        J = diff / (d * SG)[..., None]
        gn = 2.0 * np.einsum("mni,mnj->mij", J, J)
        M = np.where((ev > 0)[:, None, None], H, gn)
        step = -np.linalg.solve(M + (mu[:, None, None] * np.abs(scale)) * eye, g[..., None])[..., 0]
        xn = x + step
        fn, gn_, Hn = cost_grad_hess(xn, C, R, SG)
        ok = fn <= f
        x[ok], f[ok], g[ok], H[ok] = xn[ok], fn[ok], gn_[ok], Hn[ok]
        mu = np.where(ok, np.maximum(mu * 0.2, 1e-12), np.minimum(mu * 10, 1e12))
    # Newton polishing (exact Hessian), keep only improvements
    for _ in range(8):
        ev = np.linalg.eigvalsh(H)[:, 0]
        pd = ev > 0
        step = np.zeros_like(x)
        step[pd] = -np.linalg.solve(H[pd], g[pd][..., None])[..., 0]
        xn = x + step
        fn, gn_, Hn = cost_grad_hess(xn, C, R, SG)
        ok = fn <= f
        x[ok], f[ok], g[ok], H[ok] = xn[ok], fn[ok], gn_[ok], Hn[ok]
    ev = np.linalg.eigvalsh(H)[:, 0]
    gscale = np.sqrt(np.sum(1.0 / SG**2, axis=1)) * np.sqrt(np.maximum(f, 1e-12)) + 1e-12
    good = (np.linalg.norm(g, axis=1) <= 1e-7 * gscale) & (ev > 1e-9 * np.trace(H, axis1=1, axis2=2))
    out = []
    for k in range(S):
        sl = slice(k * K, (k + 1) * K)
        xs, fs, gd = x[sl], f[sl], good[sl]
        order = np.argsort(fs)
        kept: list[tuple[np.ndarray, float]] = []
        best = float(fs[order[0]])
        for i in order:
            if not gd[i]:
                continue
            if all(np.linalg.norm(xs[i] - p) > 1e-5 for p, _ in kept):
                kept.append((xs[i].copy(), float(fs[i])))
        out.append((best, kept))
    return out


# --- fixtures: random scenes with their brute-force minima (computed once) -----------------

N_RANDOM = 100        # scenes per landmark count
MARGIN = 1e-4         # a local minimum is non-global when its cost exceeds another one's by this


@pytest.fixture(scope="module")
def random_scenes():
    out = []
    for n in (4, 6, 8):
        rng = np.random.default_rng(1100 + n)
        c, r, s, x = scene_batch(rng, N_RANDOM, n)
        for k, (best, kept) in enumerate(local_minima(c, r, s)):
            # keep scenes whose cheapest start converged to a verified local minimum
            if kept and kept[0][1] <= best + 1e-9 * (1 + best):
                out.append((c[k], r[k], s[k], best, kept))
    assert len(out) >= 0.97 * 3 * N_RANDOM
    return out


@pytest.fixture(scope="module")
def random_certificates(random_scenes):
    certs = []
    for c, r, s, _best, kept in random_scenes:
        # the node budget decides, not the clock: a loaded machine must not change the outcome
        certs.append(ro.certify_position(ro.make_spheres(c, r, s), kept[0][0], budget_s=60.0))
    return certs


@pytest.fixture(scope="module")
def nonglobal_minima():
    """Non-global local minima of nearly coplanar scenes (robot near the plane): starts at the
    truth, its mirror across the plane and a 3^3 grid."""
    found = []
    for n, seed in ((4, 1), (5, 2)):
        rng = np.random.default_rng(1200 + seed)
        c, r, s, x = scene_batch(rng, 1000, n, coplanar=True)
        mirror = x.copy()
        mirror[:, 2] = 2 * c[:, :, 2].mean(axis=1) - x[:, 2]
        extra = np.stack([x, mirror], axis=1)
        for k, (best, kept) in enumerate(local_minima(c, r, s, grid=3, extra=extra)):
            low = min(fv for _, fv in kept) if kept else best
            for p, fv in kept:
                if fv > low + MARGIN:
                    found.append((c[k], r[k], s[k], p, fv, low))
    return found


# --- (a) global optima are certified ------------------------------------------------------

def test_global_optima_are_certified(random_certificates):
    ok = np.array([ct.certified for ct in random_certificates])
    assert ok.mean() >= 0.99, [ct.message for ct in random_certificates if not ct.certified]
    methods = {ct.method for ct in random_certificates if ct.certified}
    assert methods == {"closed_form", "branch_and_bound"}  # both proofs are exercised
    assert all(ct.method == "none" for ct in random_certificates if not ct.certified)


# --- (b) non-global local minima are never certified ---------------------------------------

def test_nonglobal_local_minima_are_refused(nonglobal_minima):
    assert len(nonglobal_minima) >= 1000
    bad = []
    for c, r, s, p, fv, low in nonglobal_minima:
        ct = ro.certify_position(ro.make_spheres(c, r, s), p, budget_s=0.2)
        assert ct.lower_bound <= low * (1 + 1e-12) + 1e-12
        assert ct.gap >= 0
        if ct.certified:
            bad.append((fv, low, ct.message))
        # at a non-global local minimum the relaxation can never be tight (lambda_bar < 0)
        assert closed_form_multiplier(c, r, s, p) < 0
    assert not bad, bad[:3]


# --- (c) the lower bound is proven: never above the brute-force minimum ---------------------

def test_lower_bound_never_exceeds_the_global_minimum(random_scenes, random_certificates):
    for (_c, _r, _s, best, kept), ct in zip(random_scenes, random_certificates, strict=True):
        assert ct.lower_bound <= best * (1 + 1e-12) + 1e-12
        assert ct.gap >= 0
        assert ct.lower_bound + ct.gap == pytest.approx(kept[0][1], rel=1e-12, abs=1e-12)
        if ct.certified:
            assert ct.gap <= max(1e-6, 1e-6 * kept[0][1]) * (1 + 1e-9)


def test_certificate_at_a_perturbed_point(random_scenes):
    # a point off the minimiser by many standard deviations is not globally optimal
    for c, r, s, best, kept in random_scenes[::10]:
        p = kept[0][0] + 0.05
        ct = ro.certify_position(ro.make_spheres(c, r, s), p, budget_s=0.2)
        f = float(np.sum(((np.linalg.norm(c - p, axis=1) - r) / s) ** 2))
        if f > best + 1e-3:
            assert not ct.certified, ct.message
        assert ct.lower_bound <= best * (1 + 1e-12) + 1e-12


# --- (d) the closed form agrees with the brute force ----------------------------------------

def test_closed_form_agrees_with_brute_force(random_scenes, random_certificates):
    closed = 0
    for (c, r, s, best, kept), ct in zip(random_scenes, random_certificates, strict=True):
        p, fv = kept[0]
        lam = closed_form_multiplier(c, r, s, p)
        if lam > 1e-9:
            closed += 1
            assert ct.certified and ct.method == "closed_form", ct.message
        if ct.method == "closed_form":
            assert lam > -1e-9
            assert fv <= best + 1e-6
            # every other local minimum costs more
            assert all(f2 >= fv - 1e-6 for _, f2 in kept)
    assert closed >= 0.2 * len(random_scenes)


def test_estimate_position_certify(random_scenes):
    for c, r, s, best, _kept in random_scenes[::15]:
        sp = ro.make_spheres(c, r, s)
        est = ro.estimate_position(sp, certify=True)
        assert est.certificate is not None
        assert est.certificate.lower_bound <= best * (1 + 1e-12) + 1e-12
        if est.certificate.certified:
            assert -2.0 * np.log(est.density) <= best + 1e-5
        assert ro.estimate_position(sp).certificate is None


def test_too_few_spheres_gets_an_uncertified_certificate():
    sp = ro.make_spheres([[0, 0, 0], [1, 0, 0]], [1.0, 1.0], 0.1)
    ct = ro.estimate_position(sp, certify=True).certificate
    assert not ct.certified and ct.method == "none" and ct.lower_bound == 0.0


def test_exact_ranges_certified_trivially():
    c = np.array([[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10.0]])
    x = np.array([3.0, 4.0, 5.0])
    ct = ro.certify_position(ro.make_spheres(c, np.linalg.norm(c - x, axis=1), 0.1), x)
    assert ct.certified and ct.lower_bound == 0.0 and ct.gap <= 1e-12


def test_budget_exhaustion_is_not_a_certificate(random_scenes):
    # a node budget of one box cannot prove anything that needs the branch and bound
    for c, r, s, _best, kept in random_scenes:
        p, _ = kept[0]
        if closed_form_multiplier(c, r, s, p) < -1e-6:
            ct = ro.certify_position(ro.make_spheres(c, r, s), p, max_nodes=1)
            assert not ct.certified and ct.method == "none"
            assert "budget" in ct.message
            break
    else:
        pytest.fail("no scene needing the branch and bound")


# --- (e) bad input ------------------------------------------------------------------------

@pytest.mark.parametrize("position, exc, name", [
    ([0.0, 0.0], ro.RadialError, r"position must have shape \(3,\), got shape \(2,\)"),
    ([[0.0, 0.0, 0.0]], ro.RadialError, r"position must have shape \(3,\), got shape \(1, 3\)"),
    ([np.nan, 0.0, 0.0], ro.RadialError, r"position\[0\] must be finite, got nan"),
    ([np.inf, 0.0, 0.0], ro.RadialError, r"position\[0\] must be finite, got inf"),
    (["a", 0.0, 0.0], ro.RadialError, "position must be an array of real numbers"),
])
def test_bad_position_raises(position, exc, name):
    sp = ro.make_spheres(np.eye(3) * 5, [1.0, 1.0, 1.0], 0.1)
    with pytest.raises(exc, match=name):
        ro.certify_position(sp, position)


@pytest.mark.parametrize("kwargs, name", [
    ({"budget_s": -1.0}, "budget_s"), ({"budget_s": np.nan}, "budget_s"),
    ({"max_nodes": 0}, "max_nodes"), ({"max_nodes": 2.5}, "max_nodes"),
    ({"rel_gap": -1e-3}, "rel_gap"), ({"abs_gap": np.inf}, "abs_gap"),
])
def test_bad_parameters_raise(kwargs, name):
    sp = ro.make_spheres(np.eye(3) * 5, [1.0, 1.0, 1.0], 0.1)
    with pytest.raises(ro.RadialError, match=name):
        ro.certify_position(sp, [0.0, 0.0, 0.0], **kwargs)


def test_bad_spheres_raise():
    with pytest.raises(ro.RadialError, match=r"spheres\[0\] must be a GaussianSphere, got object"):
        ro.certify_position([object()], [0.0, 0.0, 0.0])
    with pytest.raises(ro.RadialError, match="need at least 1 spheres, got 0"):
        ro.certify_position([], [0.0, 0.0, 0.0])
