"""Writes the API reference pages (``docs/api/<package>.rst``) when the documentation builds.

Each public object is documented once, under the shortest import path users have for it: the
package's own ``__all__`` first, then the public modules from the shallowest down (a module's
``__all__``, or the public names it defines itself). Private modules (``_name``) are left out;
every object they hold that users reach is documented where the public modules expose it.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from pathlib import Path

from sphinx.errors import PycodeError
from sphinx.pycode import ModuleAnalyzer

PACKAGES = {
    "perception": "Stereo measurement, the head's kinematic chain, fusion and recognition: from "
                  "pixels or a simulated scan to percepts in the robot's ego frame.",
    "worldgraph": "The world model, association of percepts with its objects, the 6D pose and "
                  "localisation, active looks, tiles for large maps, scenes and figures.",
    "radialopt": "Gaussian spheres in radial space: the restriction polytope, its projection, "
                 "vertex enumeration, the conformal meet, position estimation and certificates.",
}


def _public_names(module) -> list[str]:
    """``__all__`` (or else the public classes and functions the module defines), and the public
    constants it documents with a ``#:`` comment (the docstrings refer to them)."""
    try:
        commented = ModuleAnalyzer.for_module(module.__name__).find_attr_docs()
    except PycodeError:
        commented = {}
    constants = sorted(name for scope, name in commented if scope == "" and not name.startswith("_")
                       and name in vars(module))
    names = getattr(module, "__all__", None)
    if names is not None:
        return list(names) + [n for n in constants if n not in names]
    own = {n for n, obj in vars(module).items() if not n.startswith("_")
           and getattr(obj, "__module__", None) == module.__name__
           and (inspect.isclass(obj) or inspect.isfunction(obj))}
    return sorted(own | set(constants))


def _modules(package: str) -> list[str]:
    pkg = importlib.import_module(package)
    found = []
    for info in pkgutil.walk_packages(pkg.__path__, package + "."):
        if any(part.startswith("_") for part in info.name.split(".")):
            continue
        importlib.import_module(info.name)  # fails loudly on a module that cannot be imported
        found.append(info.name)
    return sorted(found, key=lambda n: (n.count("."), n))


def _key(obj, name: str) -> tuple[str, int]:
    return (name, id(obj))


def _autosummary(names: list[str]) -> list[str]:
    lines = [".. autosummary::", "   :toctree: generated", "   :nosignatures:", ""]
    lines += [f"   {n}" for n in names]
    return lines + [""]


def write_pages(out: Path) -> None:
    """Write ``out/<package>.rst`` for every package and ``out/index.rst`` linking them."""
    out.mkdir(parents=True, exist_ok=True)
    seen: set[tuple[str, int]] = set()
    for package, blurb in PACKAGES.items():
        pkg = importlib.import_module(package)
        top = _public_names(pkg)
        lines = [package, "=" * len(package), "", f".. module:: {package}", "", blurb, "",
                 "Names of the package (``import " + package + "``)",
                 "-" * (len(package) + 36), ""]
        entries = []
        for n in top:
            obj = getattr(pkg, n)
            if inspect.ismodule(obj):
                continue
            seen.add(_key(obj, n))
            entries.append(n)  # under the package the module directive above makes current
        lines += _autosummary(entries)
        for mod_name in _modules(package):
            module = importlib.import_module(mod_name)
            own = []
            for n in _public_names(module):
                obj = getattr(module, n, None)
                if obj is None or inspect.ismodule(obj) or _key(obj, n) in seen:
                    continue
                seen.add(_key(obj, n))
                own.append(n)  # under the module the automodule above makes current
            title = f"``{mod_name}``"
            lines += [title, "-" * len(title), ""]
            lines += [f".. automodule:: {mod_name}", "   :no-members:", ""]
            if own:
                lines += ["Names documented here (the others are under the package's names above):", ""]
                lines += _autosummary(own)
        (out / f"{package}.rst").write_text("\n".join(lines) + "\n")
    index = ["API reference", "=============", "",
             "Every public name, generated from the docstrings (numpydoc). Import the packages as",
             "``import perception as pc``, ``import worldgraph as wg`` and ``import radialopt as ro``;",
             "the names of each package come first, then its modules.", "",
             ".. toctree::", "   :maxdepth: 2", ""] + [f"   {p}" for p in PACKAGES]
    (out / "index.rst").write_text("\n".join(index) + "\n")


def class_aliases() -> dict[str, str]:
    """Short name -> package path of every class the three packages export (names two packages
    share would be left out, as a bare name could not say which one it means;
    there are none, a test checks)"""
    found: dict[str, set[str]] = {}
    for package in PACKAGES:
        pkg = importlib.import_module(package)
        for n in _public_names(pkg):
            if inspect.isclass(getattr(pkg, n, None)):
                found.setdefault(n, set()).add(f"{package}.{n}")
    aliases = {n: next(iter(paths)) for n, paths in found.items() if len(paths) == 1}
    # written in full: a role (numpydoc takes an alias to the same text for no alias at all)
    aliases.update({path: f":class:`{path}`" for paths in found.values() for path in paths})
    return aliases
