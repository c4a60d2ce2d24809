"""Package-level contracts: imports without OpenCV, versions, licence, status literals."""

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _run(code: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=120)


def test_import_worldgraph_does_not_load_opencv():
    # a fresh interpreter: this test process has imported cv2 long ago
    proc = _run("import worldgraph, perception, radialopt, sys; "
                "print(sorted(m for m in sys.modules if m == 'cv2' or m.startswith('cv2.')))")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"


def test_opencv_is_loaded_when_a_function_needs_it():
    # the lazy import still works: projecting through the rig imports cv2 and gives pixels
    proc = _run("import sys, numpy as np, perception; rig = perception.StereoRig.default(); "
                "assert 'cv2' not in sys.modules; uv1, uv2 = rig.project(np.array([[0.1, 0.0, 2.0]])); "
                "print('cv2' in sys.modules, np.isfinite(uv1).all())")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["True", "True"]


def test_a_fault_inside_a_public_function_surfaces_as_itself(monkeypatch):
    """Validation happens at the public boundary; an IndexError or TypeError raised inside (a bug)
    is not converted into the package's own error, so it is not mistaken for bad input."""
    import numpy as np

    import perception
    import worldgraph as wg
    from perception.errors import PerceptionError
    from perception.frontend import fusion
    from tests.worlds import four_type_world
    from worldgraph.errors import WorldGraphError
    from worldgraph.localization import pipeline

    def broken(*args, **kwargs):
        raise IndexError("an internal fault")

    percepts = [perception.Percept("door", np.array([1.0, 0.0, 0.0]), 0.01)] * 3
    monkeypatch.setattr(pipeline, "_localize", broken)
    with pytest.raises(IndexError, match="an internal fault") as info:
        wg.localize(four_type_world(), percepts)
    assert not isinstance(info.value, WorldGraphError)

    monkeypatch.setattr(fusion, "_melt", broken)
    with pytest.raises(IndexError, match="an internal fault") as info:
        perception.fuse_percepts([perception.Percept("door", np.array([1.0, 0.0, 2.0]), 0.01)] * 2)
    assert not isinstance(info.value, PerceptionError)


def _pyproject() -> dict:
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10: the test extra installs tomli
        import tomli as tomllib
    with open(ROOT / "pyproject.toml", "rb") as fh:
        return tomllib.load(fh)


def test_version_matches_pyproject():
    import perception
    import radialopt
    import worldgraph

    expected = _pyproject()["project"]["version"]
    assert [perception.__version__, worldgraph.__version__, radialopt.__version__] == [expected] * 3


def test_version_fallback_without_installed_distribution():
    # the source tree alone (no installed metadata) must report pyproject's version too
    expected = _pyproject()["project"]["version"]
    proc = _run("import importlib.metadata as md\n"
                "def missing(name):\n"
                "    raise md.PackageNotFoundError(name)\n"
                "md.version = missing\n"
                "import perception, radialopt, worldgraph\n"
                "print(perception.__version__, worldgraph.__version__, radialopt.__version__)")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == [expected] * 3


def test_licence_file_and_metadata_agree():
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("MIT License")
    assert "Copyright (c) 2026 the gaussian-spheres developers" in text
    assert _pyproject()["project"]["license"] == {"text": "MIT"}


# ---------------------------------------------------------------- statuses: Literal types

def _consts(node):
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return {node.value}
    if isinstance(node, ast.IfExp):
        return _consts(node.body) | _consts(node.orelse)
    return set()


_TOKEN = re.compile(r"^[a-z][a-z_]*$")


def _returned(node):
    """Token-like string constants a return statement gives back in a tuple (``return z,
    "optimal"``; a bare string returned is more often text than a status)."""
    out = set()
    if isinstance(node.value, ast.Tuple):
        for e in node.value.elts:
            out |= {v for v in _consts(e) if _TOKEN.match(v)}
    return out


#: Failure helpers and the position of their status argument.
_FAILERS = {"poseless_result": 0, "failed": 0, "_nan_estimate": 1}


def _returned_statuses(path):
    """String literals ``path`` hands out as a status: ``status=`` keywords, assignments to
    ``status``, the status argument of the failure helpers, token-like strings returned in a
    tuple and the values of a ``*_STATUS`` translation table; with their line numbers."""
    tree = ast.parse((ROOT / path).read_text())
    found = {}

    def add(vals, node):
        for v in vals:
            found.setdefault(v, node.lineno)

    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            for kw in node.keywords:
                if kw.arg == "status":
                    add(_consts(kw.value), node)
            name = getattr(node.func, "id", getattr(node.func, "attr", None))
            if name in _FAILERS and len(node.args) > _FAILERS[name]:
                add(_consts(node.args[_FAILERS[name]]), node)
        elif isinstance(node, ast.Return) and node.value is not None:
            add(_returned(node), node)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for t in targets:
                first = t.elts[0] if isinstance(t, ast.Tuple) and t.elts else t
                if isinstance(first, ast.Name) and first.id == "status" and node.value is not None:
                    value = node.value.elts[0] if isinstance(node.value, ast.Tuple) else node.value
                    add(_consts(value), node)
                if isinstance(t, ast.Name) and t.id.endswith("_STATUS") and isinstance(node.value, ast.Dict):
                    for v in node.value.values:
                        add(_consts(v), node)
    return found


#: The modules of the localization subpackage.
_LOCALIZE_FILES = sorted(p.relative_to(ROOT).as_posix()
                         for p in (ROOT / "worldgraph" / "localization").glob("*.py"))
_TILES_FILES = sorted(p.relative_to(ROOT).as_posix() for p in (ROOT / "worldgraph" / "tiles").glob("*.py"))
#: The modules of the radial projection: the package and the types its methods share.
_PROJECTION_FILES = sorted([*(p.relative_to(ROOT).as_posix()
                              for p in (ROOT / "radialopt" / "projection").glob("*.py")),
                            "radialopt/_projection_types.py"])


def _status_sets():
    import sys as _sys

    import radialopt
    import radialopt.comparison
    import worldgraph

    localize_module = _sys.modules["worldgraph.localization"]  # the subpackage
    return {
        # the localize package: every module of the pipeline hands out localisation statuses
        **{path: localize_module.LOCALIZE_STATUSES for path in _LOCALIZE_FILES},
        **{path: localize_module.LOCALIZE_STATUSES for path in _TILES_FILES},
        "worldgraph/active/plan.py": worldgraph.active.VIEW_STATUSES,
        "radialopt/position.py": radialopt.POSITION_STATUSES,
        **{path: radialopt.STATUSES for path in _PROJECTION_FILES},
        "radialopt/_ldp.py": radialopt.STATUSES,
        "radialopt/_dual_active_set.py": radialopt.STATUSES,
        "radialopt/formulation.py": radialopt.STATUSES,
        "radialopt/comparison.py": radialopt.comparison.RUN_STATUSES,
    }


@pytest.mark.parametrize("path", sorted(_status_sets()))
def test_every_returned_status_is_listed_in_its_literal(path):
    listed = set(_status_sets()[path])
    returned = _returned_statuses(path)
    unlisted = {s: line for s, line in returned.items() if s not in listed}
    assert not unlisted, f"{path} returns statuses missing from its Literal: {unlisted}"


def test_status_collector_finds_known_statuses():
    # the collector above must see the statuses these modules are known (by reading them) to return
    assert {"too_few_percepts", "no_association", "weak", "inconsistent", "degenerate"} <= set().union(
        *(_returned_statuses(path) for path in _LOCALIZE_FILES))
    assert {"too_few_spheres", "not_converged", "outside_region", "ambiguous"} <= set(
        _returned_statuses("radialopt/position.py"))
    assert {"optimal", "optimal_inaccurate", "infeasible", "error"} <= set().union(
        *(_returned_statuses(path) for path in _PROJECTION_FILES))


def test_status_subsets_derive_from_their_literals():
    import sys as _sys

    import radialopt
    import worldgraph

    L = _sys.modules["worldgraph.localization"]
    assert L.LOCALIZE_STATUSES == ("ok", "weak", "ambiguous", "inconsistent", "no_association",
                                   "too_few_percepts", "degenerate", "outside_region",
                                   "degenerate_coplanar", "degenerate_collinear", "not_converged")
    assert L.UNIQUE_STATUSES == ("ok", "weak")
    assert L.POSE_STATUSES == ("ok", "weak", "ambiguous")
    # the tiles' failure ranking orders exactly the statuses without a trusted pose
    assert sorted(worldgraph.tiles.FAILURE_ORDER) == sorted(set(L.LOCALIZE_STATUSES) - set(L.POSE_STATUSES))
    assert len(set(worldgraph.tiles.FAILURE_ORDER)) == len(worldgraph.tiles.FAILURE_ORDER)
    assert set(worldgraph.active._LOOK_STATUSES) == {"ok", "weak", "ambiguous", "inconsistent",
                                                    "outside_region"}
    assert worldgraph.active.VIEW_STATUSES == ("ok", "not_discriminating", "single_hypothesis")
    assert radialopt.POSITION_SUCCESS == ("ok", "ambiguous")
    assert set(radialopt.POSITION_SUCCESS) < set(radialopt.POSITION_STATUSES)
    assert radialopt.CERTIFICATE_METHODS == ("closed_form", "branch_and_bound", "sdp", "none")


def test_no_module_is_shadowed_by_a_name_of_its_package():
    # `import a.b` and `a.b` must be the same object: a module named like one of its package's
    # names (once worldgraph.localize, the function and the subpackage) makes them disagree
    import importlib
    import pkgutil

    shadowed = []
    for top in ("perception", "worldgraph", "radialopt"):
        pkg = importlib.import_module(top)
        for info in pkgutil.walk_packages(pkg.__path__, top + "."):
            module = importlib.import_module(info.name)
            parent, _, leaf = info.name.rpartition(".")
            if getattr(importlib.import_module(parent), leaf, None) is not module:
                shadowed.append(info.name)
    assert shadowed == []


def test_the_code_names_no_issue() -> None:
    """Code says what it does; which issue asked for it is the changelog's and the commits' to
    say (a docstring or comment naming an issue by its number is history, not documentation)."""
    folders = ("perception", "worldgraph", "radialopt", "tests", "benchmarks", "examples", "docs")
    found = [f"{path.relative_to(ROOT)}:{k}"
             for folder in folders
             for path in sorted((ROOT / folder).rglob("*.py"))
             if not {"_build", "auto_examples"} & set(path.relative_to(ROOT).parts)
             for k, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
             if re.search(r"\bissues? \d+", line, flags=re.IGNORECASE)]
    assert found == []
