"""One parameter name: worldgraph's public functions take ``tol=``; ``tolerances=`` is a deprecated
keyword alias that warns, gives the same answer, and may not be combined with ``tol=``."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import worldgraph as wg
from perception import Percept
from tests.worlds import four_type_world
from worldgraph.filters import consistency_graph
from worldgraph.hypotheses import is_ambiguous
from worldgraph.tiles import localize_tiled, split

WORLD = four_type_world()
R = Rotation.from_euler("z", 0.3).as_matrix()
T = np.array([2.0, 3.0, 0.5])


def _percepts(n: int = 8) -> list[Percept]:
    rng = np.random.default_rng(1)
    return [Percept(WORLD.objects[i].type, R.T @ (WORLD.positions[i] - T) + 0.02 * rng.standard_normal(3),
                    0.02) for i in range(n)]


PERCEPTS = _percepts()
#: Changes the answers (one hypothesis, cliques of at least 4), so an ignored alias would show.
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


def test_localize_alias_warns_and_equals_tol() -> None:
    new = wg.localize(WORLD, PERCEPTS, tol=TOL)
    with pytest.warns(DeprecationWarning, match=r"tol=") as record:
        old = wg.localize(WORLD, PERCEPTS, tolerances=TOL)
    assert record[0].filename == __file__  # the warning points at the caller
    _same_result(new, old)
    assert new.status == "ok"
    np.testing.assert_allclose(new.transformation[:3, 3], T, atol=0.1)
    # cliques of 9 from 8 percepts: no pose, by either name (an ignored alias would give "ok")
    nine = wg.AssociationTolerances(min_clique_size=9)
    strict = wg.localize(WORLD, PERCEPTS, tol=nine)
    with pytest.warns(DeprecationWarning, match=r"tol="):
        strict_old = wg.localize(WORLD, PERCEPTS, tolerances=nine)
    assert strict.status == strict_old.status != "ok"


def test_associate_alias_warns_and_equals_tol() -> None:
    three = PERCEPTS[:3]  # with a 1 m gate three percepts fit many object triples
    assert len(wg.associate(WORLD, three, tol=WIDE)) > 1
    one = wg.AssociationTolerances(min_tolerance=1.0, max_hypotheses=1)
    new = wg.associate(WORLD, three, tol=one)
    with pytest.warns(DeprecationWarning, match=r"associate\(tolerances=\.\.\.\) is deprecated: pass tol="):
        old = wg.associate(WORLD, three, tolerances=one)
    assert len(new) == len(old) == 1
    np.testing.assert_array_equal(new[0].world_from_ego, old[0].world_from_ego)
    assert new[0].pairs == old[0].pairs
    positional = wg.associate(WORLD, three, one)  # the third positional argument is tol
    np.testing.assert_array_equal(positional[0].world_from_ego, new[0].world_from_ego)


def test_filters_alias_warns_and_equals_tol() -> None:
    new = wg.proximity_filter(WORLD, PERCEPTS, tol=TOL)
    with pytest.warns(DeprecationWarning, match="tol="):
        old = wg.proximity_filter(WORLD, PERCEPTS, tolerances=TOL)
    assert new["candidates"] == old["candidates"]
    new_o = wg.orientation_filter(WORLD, PERCEPTS, new, tol=TOL)
    with pytest.warns(DeprecationWarning, match="tol="):
        old_o = wg.orientation_filter(WORLD, PERCEPTS, new, tolerances=TOL)
    assert new_o["candidates"] == old_o["candidates"]
    g_new = consistency_graph(WORLD, PERCEPTS, tol=TOL)
    with pytest.warns(DeprecationWarning, match="tol="):
        g_old = consistency_graph(WORLD, PERCEPTS, tolerances=TOL)
    assert sorted(g_new.edges) == sorted(g_old.edges) and len(g_new) > 0


def test_is_ambiguous_alias() -> None:
    hyps = wg.associate(WORLD, PERCEPTS[:3], tol=WIDE)
    assert len(hyps) > 1
    margin = wg.AssociationTolerances(ambiguity_margin=1e9, distinct_translation=1e-6)
    assert is_ambiguous(hyps, tol=margin)  # any two distinct poses are ambiguous at this margin
    with pytest.warns(DeprecationWarning, match="tol="):
        assert is_ambiguous(hyps, tolerances=margin)
    assert not is_ambiguous(hyps)


def test_active_and_tiled_alias() -> None:
    def look(direction: np.ndarray) -> list[Percept]:
        return []

    new = wg.active_localize(WORLD, PERCEPTS, look, max_looks=0, tol=TOL)
    with pytest.warns(DeprecationWarning, match="tol="):
        old = wg.active_localize(WORLD, PERCEPTS, look, max_looks=0, tolerances=TOL)
    _same_result(new.result, old.result)
    tiles = split(WORLD, np.zeros(len(WORLD.objects), dtype=int))
    new_t = localize_tiled(tiles, PERCEPTS, workers=1, tol=TOL)
    with pytest.warns(DeprecationWarning, match="tol="):
        old_t = localize_tiled(tiles, PERCEPTS, workers=1, tolerances=TOL)
    _same_result(new_t, old_t)
    np.testing.assert_allclose(new_t.transformation[:3, 3], T, atol=0.1)


@pytest.mark.parametrize("call", [
    lambda: wg.localize(WORLD, PERCEPTS, tol=TOL, tolerances=TOL),
    lambda: wg.associate(WORLD, PERCEPTS, TOL, tolerances=TOL),
    lambda: wg.proximity_filter(WORLD, PERCEPTS, TOL, tolerances=TOL),
    lambda: consistency_graph(WORLD, PERCEPTS, tol=TOL, tolerances=TOL),
    lambda: is_ambiguous([], tol=TOL, tolerances=TOL),
    lambda: wg.active_localize(WORLD, PERCEPTS, lambda d: [], tol=TOL, tolerances=TOL),
    lambda: localize_tiled(split(WORLD, np.zeros(20, dtype=int)), PERCEPTS, tol=TOL, tolerances=TOL),
])
def test_both_names_raise(call) -> None:
    with pytest.raises(wg.ArgumentTypeError, match=r"both tol and tolerances"):
        call()
