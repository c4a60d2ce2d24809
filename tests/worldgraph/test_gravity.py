"""Gravity as a per-call fact (worldgraph.pose.gravity): ``gravity="auto" | up vector | None`` in
associate and localize, the tilt allowance folded into the gates, the fallback to the free search,
and the levelling of percepts by an IMU's up vector."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import perception as pc
import worldgraph as wg
from perception import Percept
from perception.simulation.simulate import simulate_percepts
from worldgraph import scenes
from worldgraph.errors import WorldGraphError
from worldgraph.pose import gravity as gr
from worldgraph.pose.validation import CHI2_3_GATE

EZ = np.array([0.0, 0.0, 1.0])


@pytest.fixture(scope="module")
def site() -> scenes.Site:
    # three storeys with the same plan (up to 10 % of the modules): the free search sees
    # candidates on every storey, the gravity search only on the robot's
    return scenes.building_site(storeys=3, n_objects=6000, seed=2)


@pytest.fixture(scope="module")
def flat_world(site) -> wg.WorldModel:
    """The site's objects as a user with a map builds them: bare arrays, no flag."""
    return wg.WorldModel.from_arrays(site.world.types, site.world.positions)


def _pose(rng: np.random.Generator, site: scenes.Site, tilt_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """A robot 0.8 m above a random table, yaw random, its ego z tilted by ``tilt_deg`` about a
    random horizontal axis; and the mask of the landmarks of its storey."""
    w = site.world
    tables = np.flatnonzero(w.types == "table")
    table = tables[rng.integers(len(tables))]
    m = np.eye(4)
    az = rng.uniform(0, 2 * np.pi)
    tilt = Rotation.from_rotvec(math.radians(tilt_deg) * np.array([np.cos(az), np.sin(az), 0.0]))
    m[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * np.pi)).as_matrix() @ tilt.as_matrix()
    m[:3, 3] = w.positions[table] + [0.0, 0.0, 0.8]
    return m, site.storey == site.storey[table]


def _percepts(world: wg.WorldModel, mask: np.ndarray, pose: np.ndarray, rng: np.random.Generator,
              n_true: int = 8) -> list[Percept]:
    types, pos = list(world.types[mask]), world.positions[mask]
    percepts, truth = simulate_percepts(types, pos, pose, rng, depth_factor=1000.0, max_range=8.0,
                                        n_false=1, false_types=sorted(set(types)))
    true_idx = np.flatnonzero(truth >= 0)
    assert len(true_idx) >= n_true
    pick = np.concatenate([rng.choice(true_idx, n_true, replace=False), np.flatnonzero(truth < 0)])
    return [percepts[i] for i in rng.permutation(pick)]


def _right(res: wg.LocalizationResult, pose: np.ndarray) -> bool:
    rot = Rotation.from_matrix(pose[:3, :3] @ res.transformation[:3, :3].T).magnitude()
    return bool(np.linalg.norm(res.position - pose[:3, 3]) < 0.2 and math.degrees(rot) < 2.0)


def _views(site, world, tilt_deg, seed, n):
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        pose, mask = _pose(rng, site, tilt_deg)
        try:
            out.append((pose, _percepts(world, mask, pose, rng)))
        except AssertionError:  # too few landmarks in view: draw again
            continue
    return out


# ----------------------------------------------------------------------------------------------
# the geometry: levelling rotation, tilt angle, widening bounds
# ----------------------------------------------------------------------------------------------
@given(st.lists(st.floats(-10, 10), min_size=3, max_size=3).filter(lambda v: np.linalg.norm(v) > 1e-3))
def test_level_rotation_takes_up_to_z(v):
    L = gr.level_rotation(v)
    np.testing.assert_allclose(L @ L.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(L) > 0
    np.testing.assert_allclose(L @ (np.asarray(v) / np.linalg.norm(v)), EZ, atol=1e-12)


def test_level_rotation_is_the_smallest_one():
    # the rotation angle equals the angle between up and z (no extra yaw)
    for up in ([0.1, 0.0, 1.0], [0.0, -0.3, 1.0], [1.0, 1.0, 0.2], [0.0, 0.0, -1.0]):
        u = np.asarray(up) / np.linalg.norm(up)
        angle = Rotation.from_matrix(gr.level_rotation(up)).magnitude()
        assert angle == pytest.approx(math.acos(u[2]), abs=1e-12)


@given(st.floats(0.0, 20.0), st.floats(-5.0, 5.0), st.floats(0.0, 0.5), st.floats(0, 2 * np.pi),
       st.floats(0, 2 * np.pi))
def test_tilt_widening_bounds_every_tilt(h, dz, tilt, az, frac):
    # any rotation whose z axis is within ``tilt`` of z moves h and dz by at most the widening
    v = np.array([h, 0.0, dz])
    axis = np.array([np.cos(az), np.sin(az), 0.0])
    r = Rotation.from_rotvec(tilt * (frac / (2 * np.pi)) * axis).as_matrix()
    w = r @ v
    wh, wz = gr.tilt_widening(h, dz, tilt)
    assert abs(math.hypot(w[0], w[1]) - h) <= wh + 1e-9
    assert abs(w[2] - dz) <= wz + 1e-9


def test_tilt_widening_is_reached():
    # tilting a horizontal vector upwards by the full allowance changes dz by h sin(tilt)
    h, tilt = 8.0, math.radians(5.0)
    w = Rotation.from_rotvec([0.0, -tilt, 0.0]).as_matrix() @ np.array([h, 0.0, 0.0])
    assert w[2] == pytest.approx(gr.tilt_widening(h, 0.0, tilt)[1], rel=1e-12)


def test_tilt_angle():
    m = np.eye(4)
    m[:3, :3] = Rotation.from_rotvec([0.0, math.radians(7.0), 0.0]).as_matrix()
    assert math.degrees(gr.tilt_angle(m)) == pytest.approx(7.0)
    # with the ego up vector that the rotation maps to world z, no tilt
    assert gr.tilt_angle(m, m[:3, :3].T @ EZ) == pytest.approx(0.0, abs=1e-7)
    assert math.isnan(gr.tilt_angle(np.full((4, 4), np.nan)))


def test_bad_gravity_arguments(flat_world, site):
    percepts = _views(site, flat_world, 0.0, 1, 1)[0][1]
    for bad, message in (("up", "gravity must be 'auto', a \\(3,\\) up vector"),
                         (True, "gravity must be 'auto'.*got True"),
                         ([0.0, 0.0, 0.0], "gravity = .* must be a non-zero up vector"),
                         ([0.0, 1.0], r"gravity must have shape \(3,\)"),
                         ([np.nan, 0.0, 1.0], r"gravity\[0\] must be finite")):
        with pytest.raises(WorldGraphError, match=message):
            wg.localize(flat_world, percepts, gravity=bad)
        with pytest.raises(WorldGraphError, match=message):
            wg.associate(flat_world, percepts, gravity=bad)
    with pytest.raises(WorldGraphError, match="tilt_allowance"):
        wg.AssociationTolerances(tilt_allowance=-0.1)


# ----------------------------------------------------------------------------------------------
# auto, explicit, free
# ----------------------------------------------------------------------------------------------
def test_auto_equals_the_explicit_gravity_search_on_level_percepts(site, flat_world):
    explicit = wg.AssociationTolerances(gravity_aligned=True)
    for _pose, percepts in _views(site, flat_world, 0.0, 5, 4):
        auto = wg.localize(flat_world, percepts)
        ref = wg.localize(flat_world, percepts, tol=explicit)
        up = wg.localize(flat_world, percepts, gravity=[0.0, 0.0, 2.0])
        assert auto.search == ref.search == up.search == "gravity"
        for other in (ref, up):
            assert other.status == auto.status
            assert other.correspondences == auto.correspondences
            np.testing.assert_allclose(other.transformation, auto.transformation, atol=1e-9)
        ha = wg.associate(flat_world, percepts)
        hr = wg.associate(flat_world, percepts, tol=explicit)
        assert [h.pairs for h in ha] == [h.pairs for h in hr]
        assert {h.search for h in ha} == {"gravity"}


def test_gravity_search_answers_at_least_as_often_as_the_free_one(site, flat_world):
    right = right_free = 0
    for pose, percepts in _views(site, flat_world, 0.0, 9, 5):
        res = wg.localize(flat_world, percepts)
        right += res.status == "ok" and _right(res, pose)
        free = wg.localize(flat_world, percepts, gravity=None)
        assert free.search == "free"
        assert free.status != "ok" or _right(free, pose)
        right_free += free.status == "ok" and _right(free, pose)
    assert right >= max(right_free, 4)


def test_small_tilt_is_answered_by_the_gravity_pass(site, flat_world):
    views = _views(site, flat_world, 3.0, 21, 6)
    right = 0
    for pose, percepts in views:
        res = wg.localize(flat_world, percepts)
        assert res.search == "gravity", res.message
        assert res.status != "ok" or _right(res, pose), res.summary()
        right += res.status == "ok"
    assert right >= 5


def test_large_tilt_falls_back_to_the_free_search(site, flat_world):
    views = _views(site, flat_world, 15.0, 31, 4)
    right = 0
    for pose, percepts in views:
        res = wg.localize(flat_world, percepts)
        assert res.search == "free", res.message
        assert "answered by the free 3D search" in res.message and "gravity_pass" in res.timings
        assert res.status != "ok" or _right(res, pose), res.summary()
        right += res.status == "ok"
        # associate decides "auto" by the same rule, on its best hypothesis
        hyps = wg.associate(flat_world, percepts)
        assert hyps and all(h.search == "free" for h in hyps)
    assert right >= 3


def test_imu_up_vector_gives_the_storey_aware_answer_on_a_tilted_robot(site, flat_world):
    views = _views(site, flat_world, 15.0, 31, 4)
    right = 0
    for pose, percepts in views:
        up = pose[:3, :3].T @ EZ  # the world's up in the ego frame, as an IMU measures it
        res = wg.localize(flat_world, percepts, gravity=up)
        assert res.search == "gravity"
        assert res.status != "ok" or _right(res, pose), res.summary()
        right += res.status == "ok"
        # the same as the explicit gravity search on percepts levelled by hand
        L = gr.level_rotation(up)
        levelled = [Percept(p.type, L @ p.position, p.sigma) for p in percepts]
        lev = wg.localize(flat_world, levelled, tol=wg.AssociationTolerances(gravity_aligned=True))
        assert lev.correspondences == res.correspondences
        np.testing.assert_allclose(lev.transformation[:3, :3] @ L, res.transformation[:3, :3], atol=1e-6)
        np.testing.assert_allclose(lev.position, res.position, atol=1e-6)
    assert right >= 3


def test_a_wrong_level_answer_never_comes_back_ok_when_tilted(site, flat_world):
    # 15 degrees and nothing passed: whatever answers, "ok" only at the true pose
    for pose, percepts in _views(site, flat_world, 15.0, 41, 6):
        res = wg.localize(flat_world, percepts)
        assert res.status != "ok" or _right(res, pose), res.summary()


def test_paper_method_uses_no_gravity(site, flat_world):
    pose, percepts = _views(site, flat_world, 0.0, 3, 1)[0]
    res = wg.localize(flat_world, percepts, method="paper")
    assert res.search == "free" and "gravity" not in res.message


def test_to_dict_says_which_search_answered(site, flat_world):
    pose, percepts = _views(site, flat_world, 0.0, 3, 1)[0]
    assert wg.localize(flat_world, percepts).to_dict()["search"] == "gravity"
    assert wg.localize(flat_world, percepts, gravity=None).to_dict()["search"] == "free"


def test_tiles_decide_auto_on_the_combined_answer(site, flat_world):
    tiles = wg.tiles.split(flat_world, site.labels("storey"))
    (pose, level), = _views(site, flat_world, 0.0, 51, 1)
    res = wg.localize_tiled(tiles, level, workers=1)
    assert res.search == "gravity" and "gravity_pass" not in res.timings
    assert res.status != "ok" or _right(res, pose)
    (pose, tilted), = _views(site, flat_world, 15.0, 52, 1)
    res = wg.localize_tiled(tiles, tilted, workers=1)
    assert res.search == "free" and "answered by the free 3D search" in res.message
    assert res.status != "ok" or _right(res, pose)
    imu = wg.localize_tiled(tiles, tilted, workers=1, gravity=pose[:3, :3].T @ EZ)
    assert imu.search == "gravity"
    assert imu.status != "ok" or _right(imu, pose)
    with pytest.raises(WorldGraphError, match=r"gravity must be 'auto', a"):
        wg.localize_tiled(tiles, tilted, workers=1, gravity="down")


def test_active_localize_passes_gravity_on(site, flat_world):
    (pose, percepts), = _views(site, flat_world, 0.0, 61, 1)

    def look(direction):
        return []

    assert wg.active_localize(flat_world, percepts, look, max_looks=1).result.search == "gravity"
    assert wg.active_localize(flat_world, percepts, look, max_looks=1, gravity=None).result.search == "free"
    with pytest.raises(WorldGraphError, match=r"gravity must be 'auto', a"):
        wg.active_localize(flat_world, percepts, look, gravity="level")


def test_auto_keeps_a_gravity_answer_whose_unmatched_percepts_it_explains():
    """Four handles each sit between two handles 6 cm apart (2 cm noise): the pose explains them
    (residuals within the gate) but matches none (either twin fits), so only 4 of 8 percepts are
    matches.  Support counts the percepts the pose explains: "auto" keeps the gravity answer
    (before, 4 of 8 < 3/4 sent a level robot to the free search)."""
    rng = np.random.default_rng(3)
    uniq = np.array([[3.0, 0.0, 0.0], [0.0, 3.0, 0.5], [-3.0, 0.5, -0.4], [0.5, -3.0, 0.8]])
    kinds = ["door", "knob", "drawer", "lamp"]
    centres = np.array([[2.0, 2.0, 0.2], [-2.0, 2.0, -0.3], [-2.0, -2.0, 0.4], [2.0, -2.0, -0.1]])
    twins = np.vstack([centres + [0.03, 0, 0], centres - [0.03, 0, 0]])
    world = wg.WorldModel.from_arrays(kinds + ["handle"] * 8, np.vstack([uniq, twins]), max_link_length=8.0)
    s = 0.02
    percepts = [pc.Percept(t, x + rng.normal(0, s, 3), s, covariance=s**2 * np.eye(3))
                for t, x in zip(kinds + ["handle"] * 4, np.vstack([uniq, centres]), strict=True)]
    res = wg.localize(world, percepts)
    assert res.status == "ok" and res.search == "gravity"
    assert len(res.correspondences) == 4  # the handles are explained, not matched
    assert np.count_nonzero(res.residuals**2 <= CHI2_3_GATE) == 8
    assert np.allclose(res.transformation, np.eye(4), atol=0.05)
