"""WorldModel: bad objects, scene or source; a link table beyond its budget.

From the second adversarial audit of worldgraph: each case raised something else than
the package's error, or was accepted silently.
"""

from __future__ import annotations

import numpy as np
import pytest

import worldgraph as wg
from tests.worlds import four_type_world_and_percepts


def test_world_model_of_a_scalar_and_bad_scene_or_source() -> None:
    world, _ = four_type_world_and_percepts()
    with pytest.raises(wg.WorldGraphError, match="objects must be a sequence of ObjectModel"):
        wg.WorldModel(np.array(1.0))
    with pytest.raises(wg.WorldGraphError, match="scene must be a trimesh.Scene"):
        wg.WorldModel(world.objects, scene=float("nan"), class_vertices=world.class_vertices)
    with pytest.raises(wg.WorldGraphError, match="source must be a str"):
        wg.WorldModel.from_dict(world.to_dict(), source=object())


def test_a_link_table_beyond_its_budget_is_refused_before_it_is_built(monkeypatch) -> None:
    """20,000 objects of one type in a 10 m cube would link about 56 million pairs (1.2 GB and
    more while sorting): refused at once, naming max_link_length; the count estimated from a
    strided sample agrees with the exact count on a smaller world."""
    import worldgraph.model.links as links

    rng = np.random.default_rng(0)
    with pytest.raises(wg.WorldGraphError, match=r"max_link_length = 5 m .* about 5\d,\d{3},\d{3} object"):
        wg.WorldModel.from_arrays(["door"] * 20_000, rng.uniform(0, 10, (20_000, 3)))
    pos = rng.uniform(0, 40, (3000, 3))
    exact = wg.WorldModel.from_arrays(["door"] * 3000, pos)
    n_links = len(exact.links[("door", "door")])
    monkeypatch.setattr(links, "MAX_LINKS", int(0.8 * n_links))
    with pytest.raises(wg.WorldGraphError, match="lower max_link_length"):
        wg.WorldModel.from_arrays(["door"] * 3000, pos)
    monkeypatch.setattr(links, "MAX_LINKS", int(1.25 * n_links))
    assert len(wg.WorldModel.from_arrays(["door"] * 3000, pos).links[("door", "door")]) == n_links
