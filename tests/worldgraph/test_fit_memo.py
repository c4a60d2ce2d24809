"""The validation's refinements are shared: ``fit_hypothesis(memo=...)`` refines each inlier set
once per localisation.  Tested against the reference without the memo, hypothesis by hypothesis
and on whole ``localize`` calls (same statuses and correspondences, poses to 1e-6)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from perception import Percept
from worldgraph import localize, scenes
from worldgraph.association import associate
from worldgraph.errors import WorldGraphError
from worldgraph.localization import validate
from worldgraph.pose.validation import NearestObjects, fit_hypothesis, percept_covariances


def _trial(kind: str, seed: int, rng: np.random.Generator, n_true: int = 6) -> tuple:
    """A level robot in a layout kitchen, ``n_true`` landmarks within 7 m ahead and a false one."""
    world = scenes.kitchen_layout(kind, seed=seed)
    keep = [t for t in world.type_names if t not in scenes.STRUCTURAL_TYPES]
    world = world.subset(keep)
    lo, hi = world.bounds
    for _ in range(1000):
        pose = np.eye(4)
        pose[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * math.pi)).as_matrix()
        pose[:3, 3] = [*rng.uniform(lo[:2] + 0.4, hi[:2] - 0.4), lo[2] + 1.5]
        ego = (world.positions - pose[:3, 3]) @ pose[:3, :3]
        rho = np.linalg.norm(ego, axis=1)
        seen = np.flatnonzero((rho > 0.3) & (rho < 7.0) & (ego[:, 0] > 0.5 * rho))
        if len(seen) >= n_true:
            break
    out = []
    for o in rng.choice(seen, n_true, replace=False):
        s = float(rho[o] ** 2 / 1000.0)
        out.append(Percept(str(world.types[o]), ego[o] + rng.normal(0.0, s, 3), s))
    x = np.array([rng.uniform(1, 6), rng.uniform(-2, 2), rng.uniform(-1, 1)])
    out.append(Percept(str(world.types[rng.integers(len(world))]), x, float(x @ x) / 1000.0))
    return world, out


def test_a_memo_gives_each_hypothesis_the_fit_it_gets_alone() -> None:
    rng = np.random.default_rng(1)
    world, percepts = _trial("galley", 1, rng, n_true=4)  # a repeated galley: 10 hypotheses
    hyps = associate(world, percepts, max_hypotheses=32)
    assert len(hyps) >= 4  # the premise: several hypotheses to share refinements
    ego = np.array([p.position for p in percepts])
    covs = percept_covariances(percepts)
    nearest = NearestObjects(world, [p.type for p in percepts])
    memo: dict = {}
    for start in [h.pairs for h in hyps] + [h.all_pairs for h in hyps]:
        T = hyps[0].world_from_ego
        for h in hyps:
            if h.pairs == start or h.all_pairs == start:
                T = h.world_from_ego
        shared = fit_hypothesis(world, ego, covs, nearest, start, T, memo=memo)
        alone = fit_hypothesis(world, ego, covs, nearest, start, T)
        assert (shared is None) == (alone is None)
        if shared is not None and alone is not None:
            assert shared.pairs == alone.pairs
            assert np.allclose(shared.world_from_ego, alone.world_from_ego, atol=1e-6, rtol=0.0)
            assert shared.cost == pytest.approx(alone.cost, rel=1e-6, abs=1e-6)
            assert memo[shared.pairs] is not None and memo[shared.pairs][0] is shared
    with pytest.raises(WorldGraphError, match="memo"):
        fit_hypothesis(world, ego, covs, nearest, hyps[0].pairs, hyps[0].world_from_ego, memo=[])


def test_localize_refines_each_inlier_set_once(monkeypatch) -> None:
    import worldgraph.pose.validation as pv

    calls: list[tuple] = []
    real = pv._refinement

    def counted(*args):
        calls.append(args[4])  # the inlier set
        return real(*args)

    monkeypatch.setattr(pv, "_refinement", counted)
    rng = np.random.default_rng(1)
    trials = [_trial("u_shape", 1, rng, n_true=5) for _ in range(4)]

    def refinements() -> list[list[tuple]]:
        out = []
        for w, p in trials:
            calls.clear()
            localize(w, p)
            out.append(list(calls))
        return out

    shared = refinements()
    assert all(len(set(c)) == len(c) for c in shared)  # one refinement per inlier set and call

    def alone(*args, memo=None, **kwargs):
        return fit_hypothesis(*args, **kwargs)

    monkeypatch.setattr(validate, "fit_hypothesis", alone)
    reference = refinements()
    assert any(len(set(c)) < len(c) for c in reference)  # the reference repeats some
    assert [set(c) for c in shared] == [set(c) for c in reference]  # the same sets, each once


@pytest.mark.parametrize("kind", ["galley", "l_shape", "mixed_island"])
def test_localize_with_shared_refinements_answers_as_without(kind: str, monkeypatch) -> None:
    rng = np.random.default_rng([3, len(kind)])
    trials = [_trial(kind, s % 2, rng, n_true=5 + s % 3) for s in range(6)]
    fast = [localize(w, p) for w, p in trials]

    def alone(*args, memo=None, **kwargs):  # the reference: every refinement done afresh
        return fit_hypothesis(*args, **kwargs)

    monkeypatch.setattr(validate, "fit_hypothesis", alone)
    slow = [localize(w, p) for w, p in trials]
    for a, b in zip(fast, slow, strict=True):
        assert a.status == b.status and a.correspondences == b.correspondences
        if a.has_pose:
            assert np.allclose(a.transformation, b.transformation, atol=1e-6, rtol=0.0)
            assert np.allclose(a.pose_covariance, b.pose_covariance, rtol=1e-5, atol=1e-12)
