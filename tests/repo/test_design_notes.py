"""Every design-note citation in the code points at a section of docs/design.md that exists."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
NOTES = ROOT / "docs" / "design.md"
PACKAGES = ("perception", "worldgraph", "radialopt")
SCANNED = (*PACKAGES, "tests", "examples", "benchmarks")

#: ``docs/design.md#m2`` optionally followed by more ids: ``docs/design.md#m4, #m5, #m6``
CITATION = re.compile(r"docs/design\.md((?:#[A-Za-z0-9_-]+)(?:,\s*#[A-Za-z0-9_-]+)*)?")


def anchors() -> set[str]:
    text = NOTES.read_text(encoding="utf-8")
    return set(re.findall(r'<a id="([A-Za-z0-9_-]+)"></a>', text))


def citations(dirs: tuple[str, ...]) -> list[tuple[str, int, str | None]]:
    """(file, line, id or None for a citation without a section) of every citation."""
    out = []
    for d in dirs:
        for path in sorted((ROOT / d).rglob("*.py")):
            if path.name == Path(__file__).name:  # this file holds made-up citations on purpose
                continue
            rel = str(path.relative_to(ROOT))
            for k, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                for m in CITATION.finditer(line):
                    ids = re.findall(r"#([A-Za-z0-9_-]+)", m.group(1) or "")
                    out += [(rel, k, i) for i in ids] or [(rel, k, None)]
    return out


def test_notes_have_the_sections_the_code_relies_on() -> None:
    found = anchors()
    assert {"m1", "m2", "m3", "m4", "m5", "m6", "m7", "m8", "m9", "association",
            "solver-tolerances"} <= found
    # every anchor heads a section: the line after it is a heading
    lines = NOTES.read_text(encoding="utf-8").splitlines()
    for k, line in enumerate(lines):
        if line.startswith("<a id="):
            assert lines[k + 1].startswith("## "), f"anchor on line {k + 1} is not followed by a heading"


def test_every_citation_points_at_an_existing_section() -> None:
    found = anchors()
    cites = citations(SCANNED)
    in_packages = [c for c in cites if c[0].split("/")[0] in PACKAGES]
    assert len(in_packages) >= 10  # the code does cite the notes
    missing = [c for c in cites if c[2] is not None and c[2] not in found]
    assert not missing, f"citations of sections docs/design.md does not have: {missing}"
    bare = [c for c in in_packages if c[2] is None]
    assert not bare, f"package citations without a section id: {bare}"


@pytest.mark.parametrize("d", SCANNED)
def test_no_citation_of_the_out_of_repo_design_card(d: str) -> None:
    """``DESIGN.md`` lives outside the repository; the code cites docs/design.md instead."""
    hits = []
    for path in sorted((ROOT / d).rglob("*.py")):
        if path.name == Path(__file__).name:
            continue
        for k, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if re.search(r"\bDESIGN\b", line):
                hits.append(f"{path.relative_to(ROOT)}:{k}")
    assert not hits, f"references to DESIGN(.md): {hits}"


def test_citation_pattern_catches_a_bad_section() -> None:
    """The scanner itself: a made-up section id is reported, a list of ids is split."""
    ids = [re.findall(r"#([A-Za-z0-9_-]+)", m.group(1) or "")
           for m in CITATION.finditer("see docs/design.md#m4, #nope and docs/design.md")]
    assert ids == [["m4", "nope"], []]
    assert "nope" not in anchors()
