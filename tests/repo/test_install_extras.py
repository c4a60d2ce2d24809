"""Every module the test suite imports comes from a distribution the README's test command names:
the package's dependencies, its ``test`` extra, or one that command installs by name. Named, not
merely pulled in by another (pytest brings packaging today, Sphinx brings docutils; a release that
drops them would break a fresh machine). A test whose import only a developer's machine happens to
have (Sphinx, once, from the ``docs`` extra) fails here on every machine, not only on a fresh one.

Read statically: the imports of the tests, of the docs helpers and examples they load, and of the
three packages (whose optional imports the tests exercise), each mapped to the distribution that
provides it. Imports guarded by ``try: ... except ImportError`` are optional by design and left out.
"""

from __future__ import annotations

import ast
import re
import sys
from importlib import metadata
from pathlib import Path

from packaging.markers import default_environment
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

from tests.repo.test_readme import commands, fenced_blocks

ROOT = Path(__file__).resolve().parents[2]
SCANNED = ("tests", "perception", "worldgraph", "radialopt", "examples")
# benchmarks/ compare against optional solvers (TEASER++, open3d); the tests load only these
LOADED = ("benchmarks/oracle.py", "docs/_api.py", "docs/_xref.py", "docs/_inventories.py",
          "docs/_gallery.py", "docs/_site_checks.py")
IMPORT_ERRORS = {"ImportError", "ModuleNotFoundError"}

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - the test extra installs tomli there
    import tomli as tomllib


def _catches_import_error(handler: ast.ExceptHandler) -> bool:
    kinds = handler.type
    names = kinds.elts if isinstance(kinds, ast.Tuple) else [kinds]
    return any(isinstance(n, ast.Name) and n.id in IMPORT_ERRORS for n in names)


def required_imports(source: str) -> set[str]:
    """Top-level module names a Python source imports unconditionally (at any depth, functions
    included), and those it asks ``pytest.importorskip`` for; relative imports and imports in a
    ``try`` whose handler catches ImportError (and that handler's fallback imports) are left out,
    as is the branch of an ``if sys.version_info ...`` this Python does not take."""
    tree = ast.parse(source)
    optional: set[int] = set()
    for node in ast.walk(tree):
        skipped: list[ast.stmt] = []
        if isinstance(node, ast.Try) and any(_catches_import_error(h) for h in node.handlers):
            skipped = [*node.body, *(s for h in node.handlers for s in h.body)]  # and its fallbacks
        elif (isinstance(node, ast.If) and isinstance(node.test, ast.Compare)
              and ast.unparse(node.test.left) == "sys.version_info"
              and all(isinstance(c, ast.Constant | ast.Tuple) for c in node.test.comparators)):
            # the branch this Python does not take (``import tomllib`` / ``import tomli``)
            taken = eval(compile(ast.Expression(node.test), "<test>", "eval"), {"sys": sys})  # noqa: S307
            skipped = node.orelse if taken else node.body
        for inner in skipped:
            optional.update(id(n) for n in ast.walk(inner))
    found: set[str] = set()
    for node in ast.walk(tree):
        if id(node) in optional:
            continue
        if isinstance(node, ast.Import):
            found.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add(node.module.split(".")[0])
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
              and node.func.attr == "importorskip" and node.args
              and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
            found.add(node.args[0].value.split(".")[0])
    return found


def _local_names() -> set[str]:
    """Modules of this repository itself: its packages, and the scripts and helpers the tests put on
    ``sys.path`` (docs/_api.py, a benchmark's sibling module)."""
    names = {"tests", "docs", "conftest"}
    for folder in (ROOT, ROOT / "docs", ROOT / "benchmarks", *(ROOT / d for d in SCANNED)):
        names.update(p.stem for p in folder.rglob("*.py"))
        names.update(p.name for p in folder.iterdir() if p.is_dir() and (p / "__init__.py").is_file())
    return names


def _readme_test_command() -> list[list[str]]:
    """The simple commands of the README's second set-up block (its test command)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    setup = re.search(r"^## Set-up.*?(?=^## )", text, re.MULTILINE | re.DOTALL)
    assert setup, "README.md has no '## Set-up' section"
    blocks = fenced_blocks(setup.group(0), "bash")
    assert len(blocks) == 2, "README.md's set-up has not its two commands"
    return commands(blocks[1][1])


def named_by_the_test_command() -> set[str]:
    """Canonical names of the distributions the README's test command names: the dependencies and
    the ``test`` extra (markers evaluated here), and those its other ``pip install`` lines name."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    pips = [c for c in _readme_test_command() if c[:2] == ["pip", "install"]]
    assert ["pip", "install", "-e", ".[test]"] in pips, "the README's test command installs the test extra"
    roots = [Requirement(r) for r in [*project["dependencies"], *project["optional-dependencies"]["test"]]]
    roots += [Requirement(w) for c in pips if "-e" not in c for w in c[2:] if not w.startswith("-")]
    env = {**default_environment(), "extra": ""}
    return {canonicalize_name(r.name) for r in roots if r.marker is None or r.marker.evaluate(env)}


def test_the_import_reader_finds_required_and_leaves_optional_imports() -> None:
    source = (
        "import numpy as np\nfrom scipy.linalg import eigh\nfrom . import sibling\n"
        "def f():\n    import sphinx.util\n"
        "try:\n    import teaserpp_python\nexcept ImportError:\n    teaserpp_python = None\n"
        "try:\n    import cv2\nexcept ValueError:\n    pass\n"
        "mujoco = pytest.importorskip('mujoco')\n"
        "if sys.version_info >= (3, 0):\n    import tomllib\nelse:\n    import tomli\n")
    assert required_imports(source) == {"numpy", "scipy", "sphinx", "cv2", "mujoco", "tomllib"}


def test_every_import_of_the_suite_comes_from_a_distribution_the_readme_test_command_names() -> None:
    providers = metadata.packages_distributions()
    allowed = named_by_the_test_command()
    local = _local_names()
    wanted: dict[str, list[str]] = {}
    paths = [p for folder in SCANNED for p in sorted((ROOT / folder).rglob("*.py"))]
    for path in [*paths, *(ROOT / name for name in LOADED)]:
        for module in required_imports(path.read_text(encoding="utf-8")):
            if module not in sys.stdlib_module_names and module not in local:
                wanted.setdefault(module, []).append(str(path.relative_to(ROOT)))
    missing = []
    for module, files in sorted(wanted.items()):
        dists = {canonicalize_name(d) for d in providers.get(module, [])}
        if not dists & allowed:
            where = ", ".join(files[:3]) + (f" and {len(files) - 3} more" if len(files) > 3 else "")
            given = f"provided here by {sorted(dists)}" if dists else "installed nowhere here"
            missing.append(f"{module!r} ({given}), imported by {where}")
    assert not missing, ("imports from distributions the README's test command does not name (add "
                         "the distribution to the test extra):\n" + "\n".join(missing))
