"""The conformal meet against plain linear-algebra trilateration written independently here."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import radialopt as ro
from radialopt.conformal import as_conformal
from radialopt.spheres import conformal_sphere_sq

# --- independent references ----------------------------------------------------------------

def trilaterate(centers, radii_sq):
    """Points of three spheres: subtract the first equation (relative to the first centre),
    minimum-norm least squares, SVD null space, then the quadratic along the null line."""
    c = np.asarray(centers, float)
    rel = c - c[0]
    A = 2.0 * rel[1:]
    b = np.array([rel[j] @ rel[j] - radii_sq[j] + radii_sq[0] for j in (1, 2)])
    xp, *_ = np.linalg.lstsq(A, b, rcond=None)
    null = np.linalg.svd(A)[2][-1]
    # |xp + t null|^2 = r0^2  ->  t^2 + 2 (xp.null) t + |xp|^2 - r0^2 = 0
    roots = np.roots([1.0, 2.0 * xp @ null, xp @ xp - radii_sq[0]])
    return np.array([c[0] + xp + t.real * null for t in roots])


def radical_centre(centers, radii_sq):
    """Radical centre from all six pairwise power differences, least squares."""
    c = np.asarray(centers, float)
    origin = c[0]
    rel = c - origin
    rows, rhs = [], []
    for i in range(4):
        for j in range(i + 1, 4):
            rows.append(2.0 * (rel[j] - rel[i]))
            rhs.append(rel[j] @ rel[j] - radii_sq[j] - rel[i] @ rel[i] + radii_sq[i])
    x, *_ = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)
    return origin + x


def rotation(rng_values):
    q = np.asarray(rng_values, float)
    q = q / np.linalg.norm(q)
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


# --- strategies ----------------------------------------------------------------------------

floats = st.floats
unit_quaternion = st.lists(floats(-1, 1), min_size=4, max_size=4).map(
    lambda q: np.array(q) + np.array([1.5, 0, 0, 0]))  # bounded away from zero


@st.composite
def triangle_scene(draw, offset=0.0):
    """Three non-collinear centres, a point off their plane, exact squared radii."""
    R = rotation(draw(unit_quaternion))
    a = draw(floats(1.0, 5.0))
    b = draw(floats(1.0, 5.0))
    theta = draw(floats(0.3, np.pi - 0.3))
    local = np.array([[0, 0, 0], [a, 0, 0], [b * np.cos(theta), b * np.sin(theta), 0]])
    u = draw(floats(-3, 3))
    v = draw(floats(-3, 3))
    h = draw(floats(0.5, 4.0)) * draw(st.sampled_from([-1.0, 1.0]))
    shift = np.array([draw(floats(-5, 5)) for _ in range(3)]) + offset
    centers = local @ R.T + shift
    truth = np.array([u, v, h]) @ R.T + shift
    return centers, truth


@st.composite
def tetra_scene(draw, offset=0.0):
    """Four centres spanning 3-D (a triangle plus an apex off its plane) and a point."""
    centers, _ = draw(triangle_scene(offset=offset))
    n = np.cross(centers[1] - centers[0], centers[2] - centers[0])
    n /= np.linalg.norm(n)
    apex = centers.mean(axis=0) + draw(floats(-2, 2)) * (centers[1] - centers[0]) / 4 \
        + draw(floats(1.0, 4.0)) * n
    truth = centers.mean(axis=0) + np.array([draw(floats(-4, 4)) for _ in range(3)])
    return np.vstack([centers, apex]), truth


# --- two spheres ---------------------------------------------------------------------------

@given(triangle_scene())
def test_circle_points_lie_on_both_spheres(scene):
    centers, truth = scene
    r = np.linalg.norm(centers - truth, axis=1)
    circ = ro.meet(ro.GaussianSphere(centers[0], r[0], 1.0), ro.GaussianSphere(centers[1], r[1], 1.0))
    assert circ.status == "real"
    np.testing.assert_allclose(np.linalg.norm(circ.normal), 1.0, atol=1e-12)
    # the truth is on the circle: in its plane and at distance radius from its centre
    assert abs((truth - circ.center) @ circ.normal) < 1e-9
    assert np.linalg.norm(truth - circ.center) == pytest.approx(circ.radius, abs=1e-9)


def test_tangent_and_imaginary_circles_with_hand_values():
    a = ro.GaussianSphere([0, 0, 0], 1.0, 1.0)
    touching = ro.meet(a, ro.GaussianSphere([3, 0, 0], 2.0, 1.0))
    assert touching.status == "tangent"
    np.testing.assert_allclose(touching.center, [1, 0, 0], atol=1e-15)
    assert touching.radius == 0.0
    crossing = ro.meet(a, ro.GaussianSphere([3, 0, 0], 2.0 + 1e-6, 1.0))
    assert crossing.status == "real"
    # t = (9 + 1 - r2^2) / 6 from the first centre; radius^2 = 1 - t^2
    t = (9 + 1 - (2 + 1e-6) ** 2) / 6
    assert crossing.radius_sq == pytest.approx(1 - t * t, rel=1e-9)
    apart = ro.meet(a, ro.GaussianSphere([3, 0, 0], 2.0 - 1e-6, 1.0))
    assert apart.status == "imaginary" and apart.radius_sq < 0 and np.isnan(apart.radius)
    inside = ro.meet(ro.GaussianSphere([0, 0, 0], 5.0, 1.0), ro.GaussianSphere([1, 0, 0], 1.0, 1.0))
    assert inside.status == "imaginary"


def test_imaginary_spheres_as_conformal_vectors():
    # an imaginary sphere (radius^2 = -4) and a real one: the circle still satisfies the
    # power equation |x - c_i|^2 - r_i^2 equal for both, and radius^2 = r1^2 - |c - c1|^2
    v1 = conformal_sphere_sq([0, 0, 0], -4.0)
    v2 = conformal_sphere_sq([2, 0, 0], 9.0)
    circ = ro.meet(v1, 3.0 * v2)  # any non-zero multiple is the same sphere
    # radical plane 2*2*x = (4 - 9) - (0 + 4)  ->  x = -9/4
    np.testing.assert_allclose(circ.center, [-9 / 4, 0, 0], atol=1e-14)
    assert circ.radius_sq == pytest.approx(-4 - (9 / 4) ** 2, rel=1e-12)
    assert circ.status == "imaginary"


def test_conformal_vector_and_gaussian_sphere_give_the_same_meet():
    s = [ro.GaussianSphere(c, r, 0.1) for c, r in [([0, 0, 0], 2.0), ([2, 0, 0], 2.0), ([1, 2, 0], 2.0)]]
    a = ro.meet(*s)
    b = ro.meet(s[0].conformal(), s[1], ro.conformal_sphere(s[2].center, 2.0))
    np.testing.assert_allclose(a.points, b.points, atol=1e-14)
    c, r2 = as_conformal(-2.5 * s[1].conformal())
    np.testing.assert_allclose(c, [2, 0, 0], atol=1e-15)
    assert r2 == pytest.approx(4.0, abs=1e-14)


# --- three spheres -------------------------------------------------------------------------

@pytest.mark.parametrize("offset", [0.0, 1e4])
@given(data=st.data())
def test_point_pair_matches_independent_trilateration(offset, data):
    centers, truth = data.draw(triangle_scene(offset=offset))
    r = np.linalg.norm(centers - truth, axis=1)
    pp = ro.meet(*[ro.GaussianSphere(c, ri, 0.1) for c, ri in zip(centers, r, strict=True)])
    assert pp.status == "real"
    ref = trilaterate(centers, r**2)
    tol = 1e-9 if offset == 0 else 1e-8
    # the same two points, in some order
    d = np.linalg.norm(pp.points[:, None] - ref[None], axis=2)
    assert min(d[0, 0] + d[1, 1], d[0, 1] + d[1, 0]) < 2 * tol
    assert np.min(np.linalg.norm(pp.points - truth, axis=1)) < tol
    # points[1] lies on the +axis side of the midpoint
    assert (pp.points[1] - pp.center) @ pp.axis > 0


def test_tangent_point_pair_and_design_counterexample():
    # three unit spheres on an equilateral triangle of side 2 touch pairwise at edge midpoints
    # but have no common point; radii 2/sqrt(3) meet exactly at the circumcentre
    h = np.sqrt(3.0)
    centers = np.array([[0, 0, 0], [2, 0, 0], [1, h, 0]])
    circum = np.array([1, h / 3, 0])
    rt = 2 / np.sqrt(3)
    tangent = ro.meet(*[ro.GaussianSphere(c, rt, 1.0) for c in centers])
    assert tangent.status == "tangent"
    np.testing.assert_allclose(tangent.points, [circum, circum], atol=1e-12)
    # docs/design.md#m3: side 2, radii 1.1: every pair meets, the three do not
    cex = ro.meet(*[ro.GaussianSphere(c, 1.1, 1.0) for c in centers])
    assert cex.status == "imaginary"
    assert cex.half_distance_sq == pytest.approx(1.21 - 4 / 3, rel=1e-12)
    np.testing.assert_allclose(cex.points, [circum, circum], atol=1e-12)
    near = ro.meet(*[ro.GaussianSphere(c, rt + 1e-7, 1.0) for c in centers])
    assert near.status == "real"
    # half distance^2 = r^2 - circumradius^2
    assert near.half_distance_sq == pytest.approx((rt + 1e-7) ** 2 - rt**2, rel=1e-6)


@pytest.mark.parametrize("offset", [0.0, 1e4])
def test_near_tangent_point_pair_far_from_origin(offset):
    # three spheres through a point at a small height above the centres' plane
    rng = np.random.default_rng(3)
    centers = rng.uniform(-3, 3, size=(3, 3))
    centers[:, 2] = 0.0
    centers += offset
    size = 3.0
    for height in (1e-3, 2e-4):
        truth = np.array([0.3, -0.2, height]) + offset
        r = np.linalg.norm(centers - truth, axis=1)
        pp = ro.meet(*[ro.GaussianSphere(c, ri, 1.0) for c, ri in zip(centers, r, strict=True)])
        assert pp.status == "real"
        ref = trilaterate(centers, r**2)
        # the height comes from a square root: the error of h^2 (~ eps L (L + offset) after
        # re-centring) divided by 2h; without re-centring it would be eps offset^2 / 2h
        tol = 50 * np.finfo(float).eps * size * (size + offset) / height
        assert np.min(np.linalg.norm(pp.points - truth, axis=1)) < tol
        assert np.min(np.linalg.norm(ref - truth, axis=1)) < tol
    # h^2 = 1e-12 is below the tangent tolerance (1e-10 L^2): one point, on the plane
    truth = np.array([0.3, -0.2, 1e-6]) + offset
    r = np.linalg.norm(centers - truth, axis=1)
    pp = ro.meet(*[ro.GaussianSphere(c, ri, 1.0) for c, ri in zip(centers, r, strict=True)])
    assert pp.status == "tangent"
    np.testing.assert_allclose(pp.points, [truth - [0, 0, 1e-6]] * 2, atol=1e-6 + 1e-9 * offset)


def test_collinear_and_coincident_triples_give_a_status_not_a_point():
    line = [ro.GaussianSphere([t, 2 * t, 0], 3.0, 1.0) for t in (0.0, 1.0, 2.5)]
    pp = ro.meet(*line)
    assert pp.status == "collinear" and np.all(np.isnan(pp.points)) and "collinear" in pp.message
    twin = [ro.GaussianSphere([0, 0, 0], 1.0, 1.0), ro.GaussianSphere([0, 0, 0], 2.0, 1.0),
            ro.GaussianSphere([1, 1, 0], 1.0, 1.0)]
    assert ro.meet(*twin).status == "coincident"
    assert ro.meet(twin[0], twin[1]).status == "coincident"


# --- four spheres --------------------------------------------------------------------------

@pytest.mark.parametrize("offset", [0.0, 1e4])
@given(data=st.data())
def test_radical_centre_matches_reference_and_residual_is_the_power(offset, data):
    centers, truth = data.draw(tetra_scene(offset=offset))
    d2 = np.sum((centers - truth) ** 2, axis=1)
    power = min(data.draw(st.sampled_from([0.0, 0.37, -0.2])), 0.5 * d2.min())
    # spheres with |truth - c|^2 - r^2 = power all round: truth is their radical centre
    r2 = d2 - power
    vecs = [ro.conformal_sphere(c, np.sqrt(v)) for c, v in zip(centers, r2, strict=True)] \
        if offset == 0 else None
    spheres = [ro.GaussianSphere(c, np.sqrt(v), 1.0) for c, v in zip(centers, r2, strict=True)]
    p = ro.meet(*spheres)
    tol = 1e-9 if offset == 0 else 1e-7
    np.testing.assert_allclose(p.position, truth, atol=tol)
    np.testing.assert_allclose(p.position, radical_centre(centers, r2), atol=tol)
    assert p.residual == pytest.approx(power, abs=1e-8 if offset == 0 else 1e-6)
    assert p.status == ("real" if power == 0 else "inexact")
    if vecs is not None:
        np.testing.assert_allclose(ro.meet(*vecs).position, truth, atol=1e-9)


def test_coplanar_and_collinear_quadruples():
    flat = [ro.GaussianSphere([x, y, 1.5], 2.0, 1.0) for x, y in [(0, 0), (3, 0), (0, 3), (2, 2)]]
    p = ro.meet(*flat)
    assert p.status == "coplanar" and np.all(np.isnan(p.position)) and "coplanar" in p.message
    line = [ro.GaussianSphere([t, 0, 0], 2.0, 1.0) for t in (0, 1, 2, 4)]
    assert ro.meet(*line).status == "collinear"


# --- batched forms -------------------------------------------------------------------------

def test_batches_equal_the_scalar_meet():
    rng = np.random.default_rng(7)
    c3 = rng.uniform(-4, 4, size=(50, 3, 3))
    r3 = rng.uniform(-1, 16, size=(50, 3))
    c3[0, 2] = c3[0, 0] + 2.0 * (c3[0, 1] - c3[0, 0])  # a collinear instance
    pb = ro.meet3_batch(c3, r3)
    assert pb.points.shape == (50, 2, 3) and pb.status.shape == (50,)
    c4 = rng.uniform(-4, 4, size=(50, 4, 3))
    r4 = rng.uniform(0, 16, size=(50, 4))
    c4[1, 3] = c4[1, 0] + 0.5 * (c4[1, 1] - c4[1, 0]) + 0.25 * (c4[1, 2] - c4[1, 0])  # coplanar
    qb = ro.meet4_batch(c4, r4)
    statuses3, statuses4 = set(), set()
    for k in range(50):
        vs = [conformal_sphere_sq(c, v) for c, v in zip(c3[k], r3[k], strict=True)]
        pp = ro.meet(*vs)
        statuses3.add(pp.status)
        assert pp.status == ro.MeetStatus(int(pb.status[k])).label
        np.testing.assert_allclose(pp.points, pb.points[k], atol=1e-9, equal_nan=True)
        p = ro.meet(*[conformal_sphere_sq(c, v) for c, v in zip(c4[k], r4[k], strict=True)])
        statuses4.add(p.status)
        np.testing.assert_allclose(p.position, qb.position[k], atol=1e-9, equal_nan=True)
        if p.status == "inexact":
            np.testing.assert_allclose(p.position, radical_centre(c4[k], r4[k]), atol=1e-8)
    assert {"real", "imaginary", "collinear"} <= statuses3
    assert {"inexact", "coplanar"} <= statuses4


def test_batch_real_points_solve_the_sphere_equations():
    rng = np.random.default_rng(11)
    c = rng.uniform(-4, 4, size=(200, 3, 3))
    r2 = rng.uniform(4, 30, size=(200, 3))
    pb = ro.meet3_batch(c, r2)
    real = pb.status == ro.MeetStatus.REAL
    assert real.sum() > 20
    err = np.sum((pb.points[real][:, :, None, :] - c[real][:, None]) ** 2, axis=3) - r2[real][:, None]
    assert np.max(np.abs(err)) < 1e-9


# --- bad input -----------------------------------------------------------------------------

def test_bad_input_raises_specific_errors():
    s = ro.GaussianSphere([0, 0, 0], 1.0, 1.0)
    with pytest.raises(ro.RadialError, match="got 1"):
        ro.meet(s)
    with pytest.raises(ro.RadialError, match="got 5"):
        ro.meet(*[ro.GaussianSphere([i, i * i, 0], 1.0, 1.0) for i in range(5)])
    with pytest.raises(ro.RadialError, match="e0 coefficient"):
        ro.meet(s, [0.0, 0.0, 1.0, 0.0, 2.0])  # the plane z = 2
    with pytest.raises(ro.RadialError, match=r"shape \(4,\)"):
        ro.meet(s, [0.0, 0.0, 1.0, 0.0])
    with pytest.raises(ro.RadialError, match=r"spheres\[1\]\[1\] must be finite, got nan"):
        ro.meet(s, [0.0, np.nan, 1.0, 1.0, 0.0])
    with pytest.raises(ro.RadialError, match=r"\(k, 3, 3\)"):
        ro.meet3_batch(np.zeros((2, 4, 3)), np.zeros((2, 4)))
    with pytest.raises(ro.RadialError, match=r"radii_sq must have shape"):
        ro.meet4_batch(np.zeros((2, 4, 3)), np.zeros((2, 3)))
