"""Every public name of the packages stays importable where it was (tests/data/public_api.json,
written by ``python -m tests.public_api``; names leave it only with an entry in CHANGELOG.md)."""

from __future__ import annotations

import importlib
import json

import pytest

from tests.public_api import SNAPSHOT, api

RECORDED: dict[str, list[str]] = json.loads(SNAPSHOT.read_text())


@pytest.mark.parametrize("module", sorted(RECORDED))
def test_every_recorded_name_is_still_importable(module):
    mod = importlib.import_module(module)
    missing = [n for n in RECORDED[module] if not hasattr(mod, n)]
    assert not missing, f"{module} lost {missing}"


def test_the_snapshot_covers_the_packages():
    now = api()
    assert {"perception", "worldgraph", "radialopt", "worldgraph.localization",
            "radialopt.projection"} <= set(now)
    assert "localize" in RECORDED["worldgraph"] and "project_radii" in RECORDED["radialopt"]
    assert sum(len(v) for v in RECORDED.values()) > 500
