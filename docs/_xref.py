"""Cross-references to the library's own names, resolved by the object they name.

The API reference documents every object once, under the shortest import path users have for it
(docs/_api.py): ``worldgraph.WorldModel``, not ``worldgraph.model.world.WorldModel``.  A docstring
names an object the way its module sees it: ``WorldModel``, ``worldgraph.model.WorldModel``,
``WorldModel.save``.  Sphinx looks such a name up by text only, relative to the current module
and class, and finds nothing.  This ``missing-reference`` hook imports what the name denotes
(relative to the current class and module, then as written), finds where that object is
documented, and links there.  A name that denotes no documented object of the three packages
stays unresolved and, with ``nitpicky = True`` and ``-W``, fails the build.
"""

from __future__ import annotations

import importlib
import inspect
from typing import Any

from _api import PACKAGES  # docs/_api.py: the three packages the API reference documents
from docutils import nodes

_MISSING = object()


def _lookup(path: str) -> Any:
    """The object ``path`` (dotted) denotes, importing its longest module prefix, or _MISSING."""
    parts = path.split(".")
    if parts[0] not in PACKAGES:
        return _MISSING
    for split in range(len(parts), 0, -1):
        module_name = ".".join(parts[:split])
        try:
            obj: Any = importlib.import_module(module_name)
        except ImportError:
            continue
        for attr in parts[split:]:
            obj = _attribute(obj, attr)
            if obj is _MISSING:
                return _MISSING
        return obj
    return _MISSING


def _attribute(owner: Any, name: str) -> Any:
    """``owner.name``, a dataclass field or annotated attribute without a class-level value as a
    marker of its own (so that it can still be found under its class), or _MISSING."""
    try:
        return inspect.getattr_static(owner, name)
    except AttributeError:
        pass
    if inspect.isclass(owner) and any(name in getattr(k, "__annotations__", {}) for k in owner.__mro__):
        return _Field(owner, name)
    return _MISSING


class _Field:
    """An attribute a class declares by annotation only (a dataclass field)."""

    def __init__(self, owner: type, name: str) -> None:
        self.owner, self.name = owner, name


def _documented(app, env) -> dict[tuple[str, int], str]:
    """(last name, id of the object) -> the documented full name, for every object the Python
    domain holds from the three packages (built once per build, and kept on the application:
    the environment is pickled for the next build, where these object ids mean nothing)."""
    cache = getattr(app, "_own_objects_cache", None)
    if cache is not None:
        return cache
    cache = {}
    for fullname in env.get_domain("py").objects:
        if fullname.split(".")[0] not in PACKAGES:
            continue
        obj = _lookup(fullname)
        if obj is _MISSING:
            continue
        leaf = fullname.rsplit(".", 1)[-1]
        key = (leaf, _identity(obj))
        # the shortest documented path wins (the package's name over a module's)
        if key not in cache or len(fullname) < len(cache[key]):
            cache[key] = fullname
    app._own_objects_cache = cache
    return cache


def _identity(obj: Any) -> int:
    if isinstance(obj, _Field):
        return hash((id(obj.owner), obj.name))
    if isinstance(obj, (classmethod, staticmethod)):
        return id(obj.__func__)
    return id(obj)


def _candidates(target: str, module: str | None, cls: str | None, docname: str) -> list[str]:
    """The paths ``target`` may mean, nearest first: in the current class, in the module that
    defines the documented object (a docstring names things as its own module sees them, while
    the page documents the object under a package's name), in the current module, then in each
    enclosing package up to the top (names a package exports), then as written."""
    found = []
    modules = []
    owner = _lookup(f"{module}.{cls}") if module and cls else _MISSING
    if owner is not _MISSING:
        found.append(f"{module}.{cls}.{target}")
        modules.append(getattr(owner, "__module__", None))
    if docname.startswith("api/generated/"):  # the page of one object: its defining module
        page_object = _lookup(docname.rsplit("/", 1)[-1])
        if page_object is not _MISSING:
            modules.append(getattr(page_object, "__module__", None))
    modules.append(module)
    for name in modules:
        parts = name.split(".") if isinstance(name, str) else []
        for depth in range(len(parts), 0, -1):
            found.append(".".join(parts[:depth]) + "." + target)
    found.append(target)
    return list(dict.fromkeys(found))


def resolve_own_name(app, env, node, contnode):
    """``missing-reference`` hook: link a name of the three packages to where it is documented."""
    if node.get("refdomain") != "py":
        return None
    target = node.get("reftarget", "")
    documented = _documented(app, env)
    for path in _candidates(target, node.get("py:module"), node.get("py:class"), node.get("refdoc", "")):
        obj = _lookup(path)
        if obj is _MISSING:
            continue
        home = documented.get((path.rsplit(".", 1)[-1], _identity(obj)))
        if home is None:
            continue
        return _link(app, env, node, contnode, home)
    # a summary line in a table of the API pages has no object around it: the one documented
    # name of the package that ends the same way, if there is exactly one
    package = (node.get("py:module") or "").split(".")[0]
    if package in PACKAGES:
        homes = {home for home in documented.values()
                 if home.startswith(package + ".") and home.endswith("." + target)}
        if len(homes) == 1:
            return _link(app, env, node, contnode, homes.pop())
    return None


def _link(app, env, node, contnode, home: str):
    ref = env.get_domain("py").resolve_xref(env, node["refdoc"], app.builder, "obj", home, node, contnode)
    return ref if isinstance(ref, nodes.Element) else None


def setup(app) -> None:
    """Connect the hook (called by docs/conf.py's ``setup``)."""
    app.connect("missing-reference", resolve_own_name)
