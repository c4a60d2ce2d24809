"""Intersphinx inventories kept in the repository: the build has no network.

``docs/inventories/<project>.txt`` lists the names of another project's documentation that these
pages link to, one per line: ``name  role  uri  [shown text]`` (two or more spaces apart; the
uri relative to the ``# base:`` address in the file's first line). :func:`write_inventories`
turns each into the ``objects.inv`` format Sphinx reads (version 2: four header lines, then the
zlib-compressed entries) and returns the ``intersphinx_mapping`` that points at them. A name
missing from these files stays unresolved and fails the nitpicky build, so the lists grow with
the docstrings.
"""

from __future__ import annotations

import re
import zlib
from pathlib import Path

_FIELDS = re.compile(r"\s{2,}")


def read_inventory(path: Path) -> tuple[str, list[tuple[str, str, str, str]]]:
    """The base address and the ``(name, role, uri, shown)`` entries of one text inventory."""
    base = ""
    entries = []
    for number, line in enumerate(path.read_text().splitlines(), start=1):
        if line.startswith("# base:"):
            base = line.split(":", 1)[1].strip()
            continue
        if not line.strip() or line.startswith("#"):
            continue
        fields = _FIELDS.split(line.strip())
        if len(fields) not in (3, 4) or ":" not in fields[1]:
            raise ValueError(f"{path.name}:{number}: expected 'name  role  uri  [shown]', got {line!r}")
        name, role, uri = fields[:3]
        entries.append((name, role, uri, fields[3] if len(fields) == 4 else "-"))
    if not base.startswith("https://"):
        raise ValueError(f"{path.name}: the first line must be '# base: https://...'")
    return base, entries


def objects_inv(project: str, entries: list[tuple[str, str, str, str]]) -> bytes:
    """The bytes of an ``objects.inv`` (Sphinx inventory version 2) holding ``entries``."""
    header = (f"# Sphinx inventory version 2\n# Project: {project}\n# Version: \n"
              "# The remainder of this file is compressed using zlib.\n")
    body = "".join(f"{name} {role} 1 {uri} {shown}\n" for name, role, uri, shown in entries)
    return header.encode() + zlib.compress(body.encode())


def write_inventories(source: Path, out: Path) -> dict[str, tuple[str, str]]:
    """Write ``out/<project>.inv`` for every ``source/<project>.txt``; the intersphinx mapping."""
    out.mkdir(parents=True, exist_ok=True)
    mapping = {}
    for path in sorted(source.glob("*.txt")):
        base, entries = read_inventory(path)
        target = out / f"{path.stem}.inv"
        target.write_bytes(objects_inv(path.stem, entries))
        mapping[path.stem] = (base, str(target))
    return mapping


def class_names(source: Path) -> dict[str, str]:
    """Every class of the text inventories under its own name, as a role (numpydoc's
    parameter-type aliases; an alias to the same text would count as none)."""
    return {name: f":class:`{name}`" for path in sorted(source.glob("*.txt"))
            for name, role, _, _ in read_inventory(path)[1] if role == "py:class"}
