"""The public API of the three packages: the documented modules and the names the API reference
documents for each (``__all__``, or the classes and functions a module defines, plus the constants
it documents with ``#:``), as ``docs/_api.py`` finds them for the site.

``python -m tests.public_api`` writes ``tests/data/public_api.json``; ``tests/repo/test_public_api.py``
checks that every name listed there is still importable from the module that listed it.  Rewrite
the file only when a name is meant to go, and list the removed names in ``CHANGELOG.md``.
"""

from __future__ import annotations

import importlib
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SNAPSHOT = Path(__file__).parent / "data" / "public_api.json"
if str(ROOT / "docs") not in sys.path:
    sys.path.insert(0, str(ROOT / "docs"))  # docs/_api.py: the same rule as the API reference

import _api  # noqa: E402

PACKAGES = tuple(_api.PACKAGES)


def modules() -> list[str]:
    """The packages and their documented modules (no private module, no old path)."""
    return sorted([*PACKAGES, *(m for p in PACKAGES for m in _api._modules(p))])


def api() -> dict[str, list[str]]:
    return {m: sorted(_api._public_names(importlib.import_module(m))) for m in modules()}


if __name__ == "__main__":
    SNAPSHOT.write_text(json.dumps(api(), indent=1, sort_keys=True) + "\n")
    print(f"wrote {SNAPSHOT} ({sum(len(v) for v in api().values())} names)", file=sys.stderr)
