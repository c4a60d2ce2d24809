"""One parameter name: worldgraph's public functions take ``tol=`` and honour it; the old alias
``tolerances=`` was removed (see CHANGELOG.md) and is an unexpected keyword."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import worldgraph as wg
from perception import Percept
from tests.worlds import four_type_world
from worldgraph.association.filters import consistency_graph
from worldgraph.association.hypotheses import is_ambiguous
from worldgraph.tiles import localize_tiled, split

WORLD = four_type_world()
R = Rotation.from_euler("z", 0.3).as_matrix()
T = np.array([2.0, 3.0, 0.5])


def _percepts(n: int = 8) -> list[Percept]:
    rng = np.random.default_rng(1)
    return [Percept(WORLD.objects[i].type, R.T @ (WORLD.positions[i] - T) + 0.02 * rng.standard_normal(3),
                    0.02) for i in range(n)]


PERCEPTS = _percepts()
#: Changes the answers (one hypothesis, cliques of at least 4), so an ignored tol would show.
TOL = wg.AssociationTolerances(max_hypotheses=1, min_clique_size=4)
#: A 1 m gate: several hypotheses for three percepts.
WIDE = wg.AssociationTolerances(min_tolerance=1.0)


def _same_result(a: wg.LocalizationResult, b: wg.LocalizationResult) -> None:
    assert a.status == b.status
    np.testing.assert_array_equal(a.transformation, b.transformation)
    assert a.correspondences == b.correspondences
    assert len(a.hypotheses) == len(b.hypotheses)
    for ha, hb in zip(a.hypotheses, b.hypotheses, strict=True):
        np.testing.assert_array_equal(ha.world_from_ego, hb.world_from_ego)
        assert ha.pairs == hb.pairs


def test_localize_honours_tol() -> None:
    new = wg.localize(WORLD, PERCEPTS, tol=TOL)
    assert new.status == "ok"
    np.testing.assert_allclose(new.transformation[:3, 3], T, atol=0.1)
    # cliques of 9 from 8 percepts: no pose (an ignored tol would give "ok")
    strict = wg.localize(WORLD, PERCEPTS, tol=wg.AssociationTolerances(min_clique_size=9))
    assert strict.status != "ok"


def test_associate_honours_tol() -> None:
    three = PERCEPTS[:3]  # with a 1 m gate three percepts fit many object triples
    assert len(wg.associate(WORLD, three, tol=WIDE)) > 1
    one = wg.AssociationTolerances(min_tolerance=1.0, max_hypotheses=1)
    new = wg.associate(WORLD, three, tol=one)
    assert len(new) == 1
    positional = wg.associate(WORLD, three, one)  # the third positional argument is tol
    np.testing.assert_array_equal(positional[0].world_from_ego, new[0].world_from_ego)
    assert positional[0].pairs == new[0].pairs


def test_filters_honour_tol() -> None:
    wide = wg.proximity_filter(WORLD, PERCEPTS, tol=WIDE)
    narrow = wg.proximity_filter(WORLD, PERCEPTS, tol=TOL)
    n_wide = sum(len(c) for c in wide["candidates"])  # per percept, the surviving object indices
    n_narrow = sum(len(c) for c in narrow["candidates"])
    assert n_wide > n_narrow > 0  # a 1 m gate admits more candidates
    assert len(consistency_graph(WORLD, PERCEPTS, tol=WIDE).edges) > len(consistency_graph(WORLD, PERCEPTS,
                                                                                          tol=TOL).edges)


def test_is_ambiguous_honours_tol() -> None:
    hyps = wg.associate(WORLD, PERCEPTS[:3], tol=WIDE)
    assert len(hyps) > 1
    margin = wg.AssociationTolerances(ambiguity_margin=1e9, distinct_translation=1e-6)
    assert is_ambiguous(hyps, tol=margin)  # any two distinct poses are ambiguous at this margin
    assert not is_ambiguous(hyps)


def test_active_and_tiled_honour_tol() -> None:
    def look(direction: np.ndarray) -> list[Percept]:
        return []

    nine = wg.AssociationTolerances(min_clique_size=9)
    assert wg.active_localize(WORLD, PERCEPTS, look, max_looks=0, tol=TOL).result.status == "ok"
    assert wg.active_localize(WORLD, PERCEPTS, look, max_looks=0, tol=nine).result.status != "ok"
    tiles = split(WORLD, np.zeros(len(WORLD.objects), dtype=int))
    new_t = localize_tiled(tiles, PERCEPTS, workers=1, tol=TOL)
    assert new_t.status == "ok"
    np.testing.assert_allclose(new_t.transformation[:3, 3], T, atol=0.1)
    assert localize_tiled(tiles, PERCEPTS, workers=1, tol=nine).status != "ok"


@pytest.mark.parametrize("call", [
    lambda: wg.localize(WORLD, PERCEPTS, tolerances=TOL),
    lambda: wg.associate(WORLD, PERCEPTS, tolerances=TOL),
    lambda: wg.proximity_filter(WORLD, PERCEPTS, tolerances=TOL),
    lambda: wg.orientation_filter(WORLD, PERCEPTS, {}, tolerances=TOL),
    lambda: consistency_graph(WORLD, PERCEPTS, tolerances=TOL),
    lambda: is_ambiguous([], tolerances=TOL),
    lambda: wg.active_localize(WORLD, PERCEPTS, lambda d: [], tolerances=TOL),
    lambda: localize_tiled(split(WORLD, np.zeros(20, dtype=int)), PERCEPTS, tolerances=TOL),
])
def test_the_removed_alias_is_an_unexpected_keyword(call) -> None:
    with pytest.raises(TypeError, match=r"unexpected keyword argument 'tolerances'"):
        call()
