"""The documentation's references resolve without network: the inventories kept in
docs/inventories become objects.inv files Sphinx reads (docs/_inventories.py), and the library's
own names are found by the object they denote (docs/_xref.py). The nitpicky build in .ci/run
(``nitpicky = True`` with ``-W``) fails on any reference that neither resolves."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest
from sphinx.util.inventory import InventoryFile

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "docs"))  # docs/_xref.py imports docs/_api.py, as the build does


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / "docs" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


inventories = _load("_inventories")
xref = _load("_xref")


def test_written_inventories_load_in_sphinx_with_their_addresses(tmp_path):
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "demo.txt").write_text(
        "# base: https://example.org/doc/\n# a comment\n\n"
        "demo.Thing  py:class  api.html#demo.Thing\n"
        "a-label  std:label  guide.html#a-label  A Section\n")
    mapping = inventories.write_inventories(tmp_path / "src", tmp_path / "out")
    base, path = mapping["demo"]
    assert base == "https://example.org/doc/" and Path(path).is_file()
    with open(path, "rb") as f:
        inv = InventoryFile.load(f, base, lambda a, b: a + b)
    data = inv.data if hasattr(inv, "data") else inv  # Sphinx >= 8.2 returns an object
    thing = data["py:class"]["demo.Thing"]
    assert thing.uri == "https://example.org/doc/api.html#demo.Thing"
    assert data["std:label"]["a-label"].display_name == "A Section"


@pytest.mark.parametrize("text, message", [
    ("demo.Thing  py:class  api.html\n", "first line"),
    ("# base: https://example.org/\ndemo.Thing py:class api.html\n", "demo.txt:2"),
    ("# base: https://example.org/\ndemo.Thing  class  api.html\n", "demo.txt:2"),
])
def test_a_malformed_inventory_names_its_file_and_line(tmp_path, text, message):
    (tmp_path / "demo.txt").write_text(text)
    with pytest.raises(ValueError, match=message):
        inventories.read_inventory(tmp_path / "demo.txt")


def test_the_repository_inventories_are_well_formed():
    files = sorted((ROOT / "docs" / "inventories").glob("*.txt"))
    assert {f.stem for f in files} >= {"python", "numpy", "scipy", "trimesh", "networkx"}
    for f in files:
        base, entries = inventories.read_inventory(f)
        assert entries, f.name
        assert all(not uri.startswith(("http:", "https:", "/")) for _, _, uri, _ in entries), f.name


def test_a_docstring_name_is_looked_up_where_its_module_sees_it():
    import worldgraph
    from worldgraph.model import world

    assert xref._lookup("worldgraph.WorldModel.save") is worldgraph.WorldModel.__dict__["save"]
    assert xref._lookup("worldgraph.model.world.WorldModel") is world.WorldModel
    assert xref._lookup("numpy.ndarray") is xref._MISSING  # not one of the three packages
    assert xref._lookup("worldgraph.no_such_name") is xref._MISSING
    # a dataclass field without a class-level value is still found under its class
    field = xref._lookup("worldgraph.LocalizationResult.status")
    assert field is not xref._MISSING
    # a name on the page of worldgraph.LinkTable is tried in the defining module first, then in
    # its packages, then as written
    paths = xref._candidates("WorldModel", "worldgraph", None, "api/generated/worldgraph.LinkTable")
    assert paths == ["worldgraph.model.links.WorldModel", "worldgraph.model.WorldModel",
                     "worldgraph.WorldModel", "WorldModel"]
