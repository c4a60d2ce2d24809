"""The public API of the three packages: every module and the names it exports.

``python tests/public_api.py`` writes ``tests/data/public_api.json``; ``tests/repo/test_public_api.py``
checks that every name listed there is still importable from the module that listed it.  Rewrite
the file only when a name is meant to go (with a deprecation first), never to make the test pass
after a move: a restructuring keeps every old import path working.
"""

from __future__ import annotations

import importlib
import inspect
import json
import pkgutil
import sys
import types
from pathlib import Path

PACKAGES = ("perception", "worldgraph", "radialopt")
SNAPSHOT = Path(__file__).parent / "data" / "public_api.json"


def public_names(module: object) -> list[str]:
    """``__all__`` when the module has one, else its names without a leading underscore, less
    modules, ``__future__`` features, ``typing.TYPE_CHECKING`` and the functions and classes it
    imports from elsewhere."""
    names = getattr(module, "__all__", None)
    if names is None:
        own = getattr(module, "__name__", "")
        names = [n for n, v in vars(module).items()
                 if not n.startswith("_") and not isinstance(v, types.ModuleType)
                 and type(v).__name__ != "_Feature" and n != "TYPE_CHECKING"
                 and not ((inspect.isfunction(v) or inspect.isclass(v)) and v.__module__ != own)]
    return sorted(str(n) for n in names)


def modules() -> list[str]:
    out = []
    for name in PACKAGES:
        pkg = importlib.import_module(name)
        out.append(name)
        for info in pkgutil.walk_packages(pkg.__path__, prefix=name + "."):
            if not info.name.rsplit(".", 1)[-1].startswith("_"):
                out.append(info.name)
    return sorted(out)


def api() -> dict[str, list[str]]:
    return {m: public_names(importlib.import_module(m)) for m in modules()}


if __name__ == "__main__":
    SNAPSHOT.write_text(json.dumps(api(), indent=1, sort_keys=True) + "\n")
    print(f"wrote {SNAPSHOT} ({sum(len(v) for v in api().values())} names)", file=sys.stderr)
