"""The modules of the three packages import each other without a cycle.

Every ``import`` and ``from ... import`` statement counts, wherever it stands: at the top, inside
a function (a lazy import) or under ``if TYPE_CHECKING:``, as ``farm-studio look`` counts them.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("perception", "worldgraph", "radialopt")


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    out = {}
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            out[_module_name(path)] = path
    return out


def _source(package: str, node: ast.ImportFrom) -> str:
    """The module a ``from ... import`` statement of a module in ``package`` imports from."""
    if not node.level:
        return node.module or ""
    base = package.split(".")
    base = base[:len(base) - (node.level - 1)] if node.level > 1 else base
    return ".".join(base + ([node.module] if node.module else []))


def _imports(name: str, path: Path, known: set[str]) -> set[str]:
    """The known modules that module ``name`` imports (a ``from X import y`` of a submodule ``y``
    counts as importing ``X.y``)."""
    is_package = path.name == "__init__.py"
    package = name if is_package else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            stem = _source(package, node)
            subs = [f"{stem}.{a.name}" for a in node.names]
            # ``from pkg import mod`` imports the submodule; the package itself only for the
            # names that are not submodules
            targets = subs + ([stem] if any(t not in known for t in subs) else [])
        else:
            continue
        for t in targets:
            while t and t not in known:
                t = t.rpartition(".")[0]
            if t and t != name:
                found.add(t)
    return found


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def _graph() -> dict[str, set[str]]:
    mods = _modules()
    known = set(mods)
    return {name: _imports(name, path, known) for name, path in mods.items()}


def test_no_import_cycle():
    assert _cycles(_graph()) == []


def test_the_cycle_finder_finds_one():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _cycles(graph) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_the_import_reader_resolves_relative_and_lazy_imports(tmp_path):
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from . import b\n\ndef f():\n    from .c import thing\n")
    (pkg / "d.py").write_text("from typing import TYPE_CHECKING\n"
                              "if TYPE_CHECKING:\n    from pkg import a, x\n")
    known = {"pkg", "pkg.a", "pkg.b", "pkg.c", "pkg.d"}
    assert _imports("pkg.a", pkg / "a.py", known) == {"pkg.b", "pkg.c"}
    assert _imports("pkg.d", pkg / "d.py", known) == {"pkg", "pkg.a"}  # x is no module: the package


@pytest.mark.parametrize("package", PACKAGES)
def test_every_module_is_read(package):
    assert any(name.startswith(package + ".") for name in _modules())


# ---- the old module paths were removed ------------------------------------------------------------
#: Module paths removed (12 forwarding modules of worldgraph; perception's flat modules), with
#: the module that holds their code.
REMOVED_PATHS = {
    "worldgraph.cliques": "worldgraph.association.cliques",
    "worldgraph.consistency": "worldgraph.association.consistency",
    "worldgraph.filters": "worldgraph.association.filters",
    "worldgraph.franka": "worldgraph.importers.franka",
    "worldgraph.gravity": "worldgraph.pose.gravity",
    "worldgraph.hypotheses": "worldgraph.association.hypotheses",
    "worldgraph.plots": "worldgraph.figures.plots",
    "worldgraph.pose_certificate": "worldgraph.pose.certificate",
    "worldgraph.rerun_log": "worldgraph.figures.rerun_log",
    "worldgraph.ring_join": "worldgraph.model.ring_join",
    "worldgraph.units": "worldgraph.model.units",
    "worldgraph.validation": "worldgraph.pose.validation",
    # perception in subpackages by job
    "perception.chain": "perception.head.chain",
    "perception.classifier": "perception.recognition.classifier",
    "perception.detection": "perception.frontend.detection",
    "perception.fusion": "perception.frontend.fusion",
    "perception.outline": "perception.frontend.outline",
    "perception.percept": "perception.frontend.percept",
    "perception.render": "perception.simulation.render",
    "perception.segmentation": "perception.recognition.segmentation",
    "perception.simulate": "perception.simulation.simulate",
    "perception.stereo": "perception.head.stereo",
    "perception.uncertainty": "perception.head.uncertainty",
    "perception.urdf": "perception.head.urdf",
}


def test_no_module_forwards_to_another():
    """No module only keeps an old path alive by replacing itself in ``sys.modules``."""
    forwarding = sorted(name for name, path in _modules().items()
                        if "sys.modules[__name__]" in path.read_text())
    assert forwarding == []


@pytest.mark.parametrize("old", sorted(REMOVED_PATHS))
def test_a_removed_path_does_not_import_and_the_changelog_names_its_home(old):
    import importlib

    with pytest.raises(ModuleNotFoundError):
        importlib.import_module(old)
    package, _, leaf = old.rpartition(".")
    assert not hasattr(importlib.import_module(package), leaf), f"{package}.{leaf} is still an attribute"
    home = importlib.import_module(REMOVED_PATHS[old])
    assert home.__name__ == REMOVED_PATHS[old]
    changelog = (ROOT / "CHANGELOG.md").read_text()
    assert f"| `{old}` | `{REMOVED_PATHS[old]}` |" in changelog


def _private_imports(name: str, path: Path) -> list[tuple[str, str]]:
    """``(source module, private name)`` of every private name module ``name`` imports from a
    room it is not in. A name ``_x`` (or a private module ``_x``) belongs to the directory that
    holds it: any module in that directory or below may import it, no module elsewhere may."""
    is_package = path.name == "__init__.py"
    here = name if is_package else name.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if not isinstance(node, ast.ImportFrom):
            continue
        source = _source(here, node)
        if source.split(".")[0] not in PACKAGES:
            continue
        parts = source.split(".")
        for i, part in enumerate(parts):  # a private module on the way: its directory owns it
            if part.startswith("_") and not _inside(here, ".".join(parts[:i])):
                found.append((source, part))
                break
        source_dir = ROOT.joinpath(*parts)
        for alias in node.names:
            if not alias.name.startswith("_") or alias.name.startswith("__"):
                continue
            submodule = (source_dir / alias.name).is_dir() or (source_dir / f"{alias.name}.py").is_file()
            owner = source if (submodule or source_dir.is_dir()) else source.rpartition(".")[0]
            if not _inside(here, owner):
                found.append((source, alias.name))
    return found


def _inside(here: str, owner: str) -> bool:
    return here == owner or here.startswith(owner + ".")


def test_no_private_name_crosses_a_subpackage():
    crossing = {name: found for name, path in _modules().items() if (found := _private_imports(name, path))}
    assert crossing == {}


def test_the_private_import_reader_finds_one_across_rooms(tmp_path, monkeypatch):
    # the counter above must see a crossing where there is one, and allow one within a room
    pkg = tmp_path / "worldgraph"
    (pkg / "pose").mkdir(parents=True)
    (pkg / "tiles").mkdir()
    for d in (pkg, pkg / "pose", pkg / "tiles"):
        (d / "__init__.py").write_text("")
    (pkg / "_checks.py").write_text("def real_array(): pass\n")
    (pkg / "pose" / "gravity.py").write_text("_Plan = 1\n")
    (pkg / "pose" / "frames.py").write_text("from .gravity import _Plan\n")
    (pkg / "tiles" / "dispatch.py").write_text(
        "from .. import _checks\nfrom ..pose.gravity import _Plan, level\nfrom ..pose import gravity\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    assert _private_imports("worldgraph.pose.frames", pkg / "pose" / "frames.py") == []
    assert _private_imports("worldgraph.tiles.dispatch", pkg / "tiles" / "dispatch.py") == [
        ("worldgraph.pose.gravity", "_Plan")]
