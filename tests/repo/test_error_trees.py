"""The three error trees: a base and a few subclasses per package, no class name in two
packages, and 0.1's names kept as deprecated names of the classes that replaced them."""

from __future__ import annotations

import ast
import importlib
import inspect
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import perception as pc
import radialopt as ro
import worldgraph as wg

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = {"perception": pc.PerceptionError, "worldgraph": wg.WorldGraphError, "radialopt": ro.RadialError}
#: The class each package raises for a bad argument, a ValueError in all three.
ARGUMENT_ERRORS = {"perception": pc.PerceptionError, "worldgraph": wg.WorldGraphError,
                   "radialopt": ro.RadialArgumentError}
MAX_SUBCLASSES = 5  # "a base and the few subclasses users catch"


def _error_classes(package: str) -> dict[str, type]:
    mod = importlib.import_module(f"{package}.errors")
    return {n: c for n, c in vars(mod).items()
            if inspect.isclass(c) and issubclass(c, BaseException) and c.__module__ == mod.__name__}


@pytest.mark.parametrize("package", PACKAGES)
def test_each_tree_is_a_base_and_a_few_subclasses(package: str) -> None:
    classes = _error_classes(package)
    base = PACKAGES[package]
    assert issubclass(ARGUMENT_ERRORS[package], ValueError)
    assert ARGUMENT_ERRORS[package] is base or ARGUMENT_ERRORS[package] in classes.values()
    assert set(classes) == set(importlib.import_module(f"{package}.errors").__all__)
    subclasses = {n for n, c in classes.items() if c is not base}
    assert all(issubclass(classes[n], base) for n in subclasses)
    assert 1 <= len(subclasses) <= MAX_SUBCLASSES, sorted(subclasses)
    for n in subclasses:  # each subclass is exported by its package, as the docs list it
        assert getattr(importlib.import_module(package), n) is classes[n]


def test_no_error_class_name_is_defined_in_two_packages() -> None:
    seen: dict[str, str] = {}
    for package in PACKAGES:
        for name in _error_classes(package):
            assert name not in seen, f"{name} is defined in {seen[name]} and {package}"
            seen[name] = package


def test_every_exception_class_lives_in_its_package_errors_module() -> None:
    stray = []
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            if path.name == "errors.py" and path.parent.name == package:
                continue
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.ClassDef) and any(
                        (isinstance(b, ast.Name) and b.id.endswith(("Error", "Exception")))
                        or (isinstance(b, ast.Attribute) and b.attr.endswith(("Error", "Exception")))
                        for b in node.bases):
                    stray.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name}")
    assert stray == []


@pytest.mark.parametrize("package", PACKAGES)
def test_a_deprecated_name_warns_and_gives_the_class_that_replaced_it(package: str) -> None:
    errors = importlib.import_module(f"{package}.errors")
    pkg = importlib.import_module(package)
    assert errors.DEPRECATED_NAMES  # 0.1's names are listed
    for name, cls in errors.DEPRECATED_NAMES.items():
        assert name not in _error_classes(package)  # a deprecated name is no class of its own
        assert issubclass(cls, PACKAGES[package])
        for where in (errors, pkg):
            with pytest.warns(DeprecationWarning, match=rf"{where.__name__}\.{name} is deprecated.*"
                                                        rf"catch {package}\.{cls.__name__}"):
                assert getattr(where, name) is cls
    with pytest.raises(AttributeError, match="no attribute 'NoSuchError'"):
        _ = pkg.NoSuchError
    with pytest.raises(AttributeError, match="no attribute 'NoSuchError'"):
        _ = errors.NoSuchError


@pytest.mark.parametrize("module, names, cls", [
    ("radialopt.vertices", ["EmptyPolyhedronError", "NotPointedError", "TooLargeError"],
     ro.RadialArgumentError),
    ("perception.middlebury", ["MissingDataError"], pc.MissingExtraError),
])
def test_error_names_other_modules_exported_are_deprecated_there_too(module: str, names: list[str],
                                                                      cls: type) -> None:
    mod = importlib.import_module(module)
    for name in names:
        with pytest.warns(DeprecationWarning, match=rf"{module}\.{name} is deprecated"):
            assert getattr(mod, name) is cls
    with pytest.raises(AttributeError, match="no attribute 'ShapeError'"):
        _ = mod.ShapeError  # only the names the module itself exported


def test_files_keep_their_own_subclass_under_the_old_names() -> None:
    with pytest.warns(DeprecationWarning):
        assert pc.CalibrationFileError is pc.URDFError is pc.RobotFileError
    with pytest.warns(DeprecationWarning):
        assert pc.SceneError is pc.PerceptionError  # its "no free floor" and "no OpenGL" cases are not files


def test_an_except_clause_naming_an_old_class_still_catches_its_errors(tmp_path: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        with pytest.raises(ro.ShapeError, match=r"center must have shape \(3,\)"):
            ro.GaussianSphere([0.0, 0.0], 1.0, 0.1)
        with pytest.raises(wg.NonFiniteError, match=r"positions\[0, 1\] must be finite"):
            wg.WorldModel.from_arrays(["door"], [[0.0, np.nan, 0.0]])
        with pytest.raises(pc.NonPositiveSigmaError, match="sigma"):
            pc.Percept("door", [1.0, 0.0, 0.0], -0.1)
        missing = tmp_path / "missing.yaml"
        with pytest.raises(pc.CalibrationFileError, match="missing.yaml"):
            pc.StereoRig.from_file(missing)


def test_no_file_of_the_repository_uses_a_deprecated_name() -> None:
    names = set()
    for package in PACKAGES:
        names |= set(importlib.import_module(f"{package}.errors").DEPRECATED_NAMES)
    pattern = re.compile(r"\b(" + "|".join(sorted(names)) + r")\b")
    allowed = {Path(f"{p}/errors.py") for p in PACKAGES} | {  # where the deprecated names are kept
        Path("radialopt/vertices.py"), Path("perception/middlebury.py"),
        Path("tests/repo/test_error_trees.py")}
    hits = []
    for sub in ("perception", "worldgraph", "radialopt", "tests", "examples", "benchmarks", "docs"):
        for path in sorted((ROOT / sub).rglob("*")):
            rel = path.relative_to(ROOT)
            if (path.suffix not in (".py", ".md", ".rst") or rel in allowed or "_build" in rel.parts
                    or rel.parts[:2] in {("docs", "api"), ("docs", "auto_examples")}):
                continue
            text = path.read_text(encoding="utf-8")
            if path.suffix == ".md":  # a paragraph or table row that says "0.1" is history
                text = "\n\n".join(p for p in re.split(r"\n\s*\n", text) if "0.1" not in p)
                text = "\n".join(row for row in text.splitlines() if "0.1" not in row)
            hits += [f"{rel}: {line.strip()[:80]}" for line in text.splitlines() if pattern.search(line)]
    assert hits == []
