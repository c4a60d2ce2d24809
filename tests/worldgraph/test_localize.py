"""Tests of worldgraph.localize: the whole pipeline, invariances, statuses, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import radialopt as ro
from perception import Percept
from perception.simulation.simulate import simulate_percepts
from worldgraph.errors import WorldGraphError
from worldgraph.localization import localize
from worldgraph.model import WorldModel

TYPES = ("door", "handle", "knob", "drawer")
seeds = st.integers(0, 2**32 - 1)


def random_world(rng: np.random.Generator, n: int = 120) -> WorldModel:
    pos = rng.uniform([0, 0, 0], [12.0, 10.0, 2.5], (n, 3))
    return WorldModel.from_arrays(rng.choice(TYPES, n), pos, max_link_length=5.0, link_margin=0.5)


def yaw_pose(rng: np.random.Generator, world: WorldModel) -> np.ndarray:
    lo, hi = world.bounds
    m = np.eye(4)
    m[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * np.pi)).as_matrix()
    m[:2, 3] = rng.uniform(lo[:2] + 1.0, hi[:2] - 1.0)
    m[2, 3] = 1.5
    return m


def exact_percepts(world: WorldModel, world_from_ego: np.ndarray, idx, sigma: float = 1e-3) -> list[Percept]:
    ego = (world.positions[idx] - world_from_ego[:3, 3]) @ world_from_ego[:3, :3]
    return [Percept(str(world.types[o]), e, sigma) for o, e in zip(idx, ego, strict=True)]


def nearest(world: WorldModel, pose: np.ndarray, k: int) -> np.ndarray:
    return np.argsort(np.linalg.norm(world.positions - pose[:3, 3], axis=1))[:k]


def rotation_error_deg(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(Rotation.from_matrix(a[:3, :3].T @ b[:3, :3]).magnitude()))


@settings(max_examples=10)
@given(seeds, st.sampled_from(["ml", "spheres", "paper"]))
def test_noise_free_pose_is_exact(seed: int, method: str) -> None:
    rng = np.random.default_rng(seed)
    world = random_world(rng)
    pose = yaw_pose(rng, world)
    truth = nearest(world, pose, 6)
    res = localize(world, exact_percepts(world, pose, truth), method)
    assert res.status == "ok", res.message
    assert not res.ambiguous
    assert np.allclose(res.transformation, pose, atol=2e-3)
    assert np.allclose(res.position, res.transformation[:3, 3])
    assert sorted(res.correspondences) == [(p, int(o)) for p, o in enumerate(truth)]
    assert set(res.timings) == {"association", "validation", "radial", "position", "orientation", "total"}
    assert res.timings["total"] >= res.timings["association"] >= 0


@settings(max_examples=10)
@given(seeds)
def test_noisy_percepts_with_a_false_one_reach_the_crlb_gate(seed: int) -> None:
    rng = np.random.default_rng(seed)
    world = random_world(rng, n=150)
    pose = yaw_pose(rng, world)
    percepts, truth = simulate_percepts(list(world.types), world.positions, pose, rng, max_range=5.0,
                                        depth_factor=1000.0, n_false=1)
    keep = np.concatenate([np.flatnonzero(truth >= 0)[:7], np.flatnonzero(truth < 0)])
    percepts = [percepts[i] for i in keep]
    truth = truth[keep]
    res = localize(world, percepts)
    assert res.status == "ok", res.message
    assert all(truth[p] == o for p, o in res.correspondences)
    e = res.position - pose[:3, 3]
    # e^T J e is chi-square(3): 30 is beyond its 99.9999 % quantile
    assert e @ np.linalg.inv(res.covariance) @ e < 30.0
    assert rotation_error_deg(res.transformation, pose) < 2.0


@settings(max_examples=8)
@given(seeds)
def test_rigid_motion_and_percept_order(seed: int) -> None:
    rng = np.random.default_rng(seed)
    world = random_world(rng)
    pose = yaw_pose(rng, world)
    truth = nearest(world, pose, 6)
    percepts = [Percept(p.type, p.position + rng.normal(scale=0.01, size=3), 0.01)
                for p in exact_percepts(world, pose, truth)]
    move = np.eye(4)
    move[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * np.pi)).as_matrix()
    move[:3, 3] = rng.uniform(-20, 20, 3)
    moved = WorldModel.from_arrays(world.types, world.positions @ move[:3, :3].T + move[:3, 3],
                                   max_link_length=5.0, link_margin=0.5)
    a = localize(world, percepts)
    b = localize(moved, percepts)
    assert a.status == b.status == "ok"
    assert np.allclose(move @ a.transformation, b.transformation, atol=1e-6)
    perm = rng.permutation(len(percepts))
    c = localize(world, [percepts[i] for i in perm])
    assert np.allclose(a.transformation, c.transformation, atol=1e-9)
    assert sorted(a.correspondences) == sorted((int(perm[p]), o) for p, o in c.correspondences)


def test_coplanar_landmarks_mirror_resolved_by_the_3d_pose() -> None:
    rng = np.random.default_rng(2)
    pos = np.column_stack([rng.uniform(0, 8, 40), rng.uniform(0, 8, 40), np.full(40, 1.0)])
    world = WorldModel.from_arrays(rng.choice(TYPES, 40), pos, max_link_length=6.0)
    pose = np.eye(4)
    pose[:3, 3] = [4.0, 4.0, 1.6]
    truth = nearest(world, pose, 6)
    big = ro.Region([-50, -50, -50], [50, 50, 50])  # keeps both mirror candidates
    for method in ("spheres", "ml"):
        res = localize(world, exact_percepts(world, pose, truth, sigma=1e-3), method, region=big)
        assert res.status == "ok", res.message
        assert np.allclose(res.position, pose[:3, 3], atol=1e-3)


def test_symmetric_world_is_ambiguous() -> None:
    rng = np.random.default_rng(11)
    base = rng.uniform([0, 0, 0], [4, 4, 2.5], (6, 3))
    types = np.array(["door", "handle", "knob", "drawer", "handle", "knob"])
    world = WorldModel.from_arrays(np.concatenate([types, types]), np.vstack([base, base + [30.0, 0, 0]]),
                                   max_link_length=6.0)
    pose = np.eye(4)
    pose[:3, 3] = [2.0, 2.0, 1.2]
    res = localize(world, exact_percepts(world, pose, np.arange(6)))
    assert res.status == "ambiguous"
    assert res.ambiguous
    assert "ambiguous" in res.message
    assert len(res.hypotheses) >= 2


def test_statuses_for_too_few_and_unmatched_percepts() -> None:
    rng = np.random.default_rng(4)
    world = random_world(rng)
    pose = yaw_pose(rng, world)
    truth = nearest(world, pose, 5)
    percepts = exact_percepts(world, pose, truth)
    res = localize(world, percepts[:2])
    assert res.status == "too_few_percepts"
    assert np.all(np.isnan(res.transformation))
    assert localize(world, []).status == "too_few_percepts"
    # percepts 40 m apart: no pair of model objects is that far apart
    far = [Percept("door", [40.0 * k, 0.0, 0.0], 1e-3) for k in range(4)]
    res = localize(world, far)
    assert res.status == "no_association"
    assert np.all(np.isnan(res.position))


def test_unknown_types_are_ignored_then_rejected() -> None:
    rng = np.random.default_rng(6)
    world = random_world(rng)
    pose = yaw_pose(rng, world)
    truth = nearest(world, pose, 5)
    percepts = exact_percepts(world, pose, truth)
    window = Percept("window", [1.0, 2.0, 0.5], 1e-3)
    res = localize(world, [window] + percepts)
    assert res.status == "ok"
    assert "window" in res.message
    assert sorted(res.correspondences) == [(p + 1, int(o)) for p, o in enumerate(truth)]
    assert np.allclose(res.transformation, pose, atol=2e-3)
    with pytest.raises(WorldGraphError, match=r"no percept type is in the world.*window"):
        localize(world, [window, window, window])


def test_bad_input() -> None:
    world = random_world(np.random.default_rng(0), n=20)
    ok = [Percept("door", [1.0, 0, 0], 0.01)] * 3
    with pytest.raises(WorldGraphError, match="method"):
        localize(world, ok, "newton")
    with pytest.raises(WorldGraphError, match="WorldModel"):
        localize(np.zeros((3, 3)), ok)  # type: ignore[arg-type]
    with pytest.raises(WorldGraphError, match="Percept"):
        localize(world, [np.array([1.0, 2.0, 3.0])])  # type: ignore[list-item]
    with pytest.raises(WorldGraphError, match="AssociationTolerances"):
        localize(world, ok, tol={"n_sigma": 3})  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def kitchen() -> WorldModel:
    from worldgraph import scenes

    return scenes.kitchen(seed=0, link_margin=0.5)


def test_kitchen_with_a_false_percept_is_right_or_says_so(kitchen: WorldModel) -> None:
    rng = np.random.default_rng(123)
    mask = np.isin(kitchen.types, ("door", "handle", "drawer", "knob"))
    types, pos, glob = list(kitchen.types[mask]), kitchen.positions[mask], np.flatnonzero(mask)
    lo, hi = kitchen.bounds
    done = 0
    while done < 6:
        pose = np.eye(4)
        pose[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * np.pi)).as_matrix()
        pose[:3, 3] = [*rng.uniform(lo[:2] + 0.5, hi[:2] - 0.5), 1.5]
        percepts, truth = simulate_percepts(types, pos, pose, rng, max_range=8.0, n_false=1)
        true_idx = np.flatnonzero(truth >= 0)
        if len(true_idx) < 8:
            continue
        pick = np.concatenate([rng.choice(true_idx, 8, replace=False), np.flatnonzero(truth < 0)])
        res = localize(kitchen, [percepts[i] for i in pick])
        assert res.status in ("ok", "ambiguous"), res.message
        if res.status == "ok":
            t = truth[pick]
            assert all(t[p] < 0 or glob[t[p]] == o or np.linalg.norm(
                kitchen.positions[o] - kitchen.positions[glob[t[p]]]) < 0.2 for p, o in res.correspondences)
            assert np.linalg.norm(res.position - pose[:3, 3]) < 0.3
            assert rotation_error_deg(res.transformation, pose) < 5.0
        done += 1


def test_raw_percepts_of_a_scan_get_a_note_and_fused_ones_do_not():
    import perception as pc
    from worldgraph import scenes

    world = scenes.kitchen(seed=0)
    rng = np.random.default_rng(0)
    truth = np.eye(4)
    lower, upper = world.bounds
    truth[:3, 3] = [(lower[0] + upper[0]) / 2, (lower[1] + upper[1]) / 2, 1.6]
    seen = np.isin(world.types, ("door", "handle", "drawer", "knob"))
    raw = pc.simulate_scan(world.types[seen].tolist(), world.positions[seen], truth, rng, n_views=10)
    note = "look like the raw percepts of several views"
    assert note in localize(world, raw).message
    fused = pc.fuse_percepts(raw, bandwidth={"door": 0.3, "drawer": 0.3, "handle": 0.1, "knob": 0.1})
    assert note not in localize(world, fused).message
    # one view of distinct objects (views == 1, none close to another of its type): no note
    one, _ = pc.simulate_percepts(world.types[seen].tolist(), world.positions[seen], truth, rng)
    assert note not in localize(world, one).message
