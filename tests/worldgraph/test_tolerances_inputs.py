"""AssociationTolerances: pair_tolerance's sigmas and broadcasting, min_clique_size.

From the second adversarial audit of worldgraph: each case raised something else than
the package's error, or was accepted silently.
"""

from __future__ import annotations

import numpy as np
import pytest

import worldgraph as wg


@pytest.mark.parametrize("sigma, error, text", [
    (None, wg.WorldGraphError, "sigma_p must be an array of real numbers, got None"),
    (float("nan"), wg.WorldGraphError, "sigma_p must be finite, got nan"),
    (-1.0, wg.WorldGraphError, "sigma_p must be >= 0, got -1.0"),
    (1j, wg.WorldGraphError, "sigma_p must be real"),
    (1e300, wg.WorldGraphError, r"sigma_p must be <= 1e\+150 in magnitude, got 1e\+300"),
])
def test_pair_tolerance_checks_its_sigmas(sigma: object, error: type, text: str) -> None:
    with pytest.raises(error, match=text):
        wg.ASSOCIATION_TOLERANCES.pair_tolerance(sigma, 0.1)


def test_pair_tolerance_value_and_broadcasting() -> None:
    tol = wg.AssociationTolerances(n_sigma=3.0, pair_factor=1.0, min_tolerance=0.01)
    assert tol.pair_tolerance(0.3, 0.4) == pytest.approx(3.0 * 0.5 + 0.01)
    np.testing.assert_allclose(tol.pair_tolerance(np.array([0.3, 0.0]), 0.4), [1.51, 1.21])
    with pytest.raises(wg.WorldGraphError, match=r"sigma_p \(2,\) and sigma_q \(3,\) do.*broadcast"):
        tol.pair_tolerance(np.ones(2), np.ones(3))


def test_min_clique_size_above_the_search_size_names_both_fields() -> None:
    with pytest.raises(wg.WorldGraphError, match="min_clique_size = 30 exceeds max_search_percepts = 10"):
        wg.AssociationTolerances(min_clique_size=30)
    assert wg.AssociationTolerances(min_clique_size=30, max_search_percepts=40).min_clique_size == 30
