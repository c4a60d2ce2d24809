"""The modules of the three packages import each other without a cycle (issue 26).

Every ``import`` and ``from ... import`` statement counts, wherever it stands: at the top, inside
a function (a lazy import) or under ``if TYPE_CHECKING:``, as ``farm-studio look`` counts them.
"""

from __future__ import annotations

import ast
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
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)] if node.level > 1 else base
                stem = ".".join(base + ([node.module] if node.module else []))
            else:
                stem = node.module or ""
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


# ---- the old module paths kept after the restructuring -------------------------------------------
def _shims() -> dict[str, Path]:
    """Modules that only keep an old import path: they replace themselves in ``sys.modules`` by the
    module that now holds their code."""
    return {name: path for name, path in _modules().items()
            if "sys.modules[__name__] = " in path.read_text()}


def test_the_shims_are_their_new_homes():
    import importlib
    import sys

    shims = _shims()
    assert len(shims) >= 10  # worldgraph.consistency, .franka, .units, ... (issue 26)
    for name, path in shims.items():
        module = importlib.import_module(name)
        assert module is sys.modules[name]
        assert module.__name__ != name, f"{name} did not hand over to its new home"
        assert Path(module.__file__).resolve() != path.resolve()
        # the new home is a module of the same package, and its name says where it lives
        assert module.__name__.split(".")[0] == name.split(".")[0]


def test_nothing_inside_the_packages_imports_a_shim():
    shims = set(_shims())
    graph = _graph()
    offenders = sorted(f"{m} imports {s}" for m, deps in graph.items() if m not in shims
                       for s in deps & shims)
    assert offenders == []
