"""The built site reads offline and names no machine: a ``build-finished`` hook of docs/conf.py.

Every HTML page of the build is scanned for

- resources loaded from another host (``<script src>``, ``<link href>`` of stylesheets, icons and
  preloads, ``<img src>``, ``<source src>``, ``<iframe src>``, and ``url(...)`` in inline styles
  with an ``http:``, ``https:`` or protocol-relative address); plain links (``<a href>``) to other
  sites are fine: they load nothing;
- builder paths: absolute paths of the machine that built it (the repository's own directory,
  home and temporary directories, a Python installation's ``site-packages``).

Either fails the build, naming the page and what was found.
"""

from __future__ import annotations

import re
from pathlib import Path

#: Tags and attributes that make a browser fetch something when the page loads.
_LOADING = re.compile(
    r"<(?P<tag>script|img|source|iframe|embed|audio|video)\b[^>]*?\bsrc\s*=\s*[\"'](?P<url>[^\"']+)[\"']"
    r"|<link\b(?=[^>]*\brel\s*=\s*[\"'][^\"']*(?:stylesheet|icon|preload|modulepreload)[^\"']*[\"'])"
    r"[^>]*?\bhref\s*=\s*[\"'](?P<href>[^\"']+)[\"']"
    r"|url\(\s*[\"']?(?P<css>[^)\"']+)",
    re.IGNORECASE,
)
_REMOTE = re.compile(r"^(?:https?:)?//", re.IGNORECASE)
#: Absolute paths that only make sense on the machine that built the site.
_MACHINE_PATHS = (r"/home/[^/\s\"'<]+/", r"/root/", r"/tmp/", r"/work/", r"/Users/[^/\s\"'<]+/",
                  r"site-packages", r"[A-Za-z]:\\\\Users\\\\")


def remote_loads(html: str) -> list[str]:
    """Addresses on other hosts that ``html`` loads (scripts, styles, images, frames, CSS urls)."""
    found = []
    for m in _LOADING.finditer(html):
        url = m.group("url") or m.group("href") or m.group("css") or ""
        if _REMOTE.match(url.strip()):
            found.append(url.strip())
    return found


def builder_paths(html: str, extra: tuple[str, ...] = ()) -> list[str]:
    """Machine-specific absolute paths in ``html`` (``extra``: more literal paths to look for,
    e.g. the repository's directory)."""
    patterns = [*_MACHINE_PATHS, *(re.escape(p) for p in extra if p)]
    found = []
    for pattern in patterns:
        for m in re.finditer(pattern, html):
            start = max(0, m.start() - 30)
            found.append(html[start:m.end() + 30].replace("\n", " "))
    return found


def check_site(outdir: Path, repository: Path | None = None) -> list[str]:
    """Every problem of the built site under ``outdir``, one line each (empty when it is clean)."""
    extra = (str(repository),) if repository is not None else ()
    problems = []
    for page in sorted(Path(outdir).rglob("*.html")):
        text = page.read_text(encoding="utf-8", errors="replace")
        rel = page.relative_to(outdir)
        problems += [f"{rel}: loads {url} from another host" for url in remote_loads(text)]
        problems += [f"{rel}: builder path ...{snippet}..." for snippet in builder_paths(text, extra)]
    return problems


def check_built_site(app, exception) -> None:
    """``build-finished`` hook: fail the HTML build when :func:`check_site` finds anything."""
    if exception is not None or app.builder.format != "html":
        return
    problems = check_site(Path(app.outdir), Path(app.srcdir).parent)
    if problems:
        shown = "\n  ".join(problems[:20])
        more = f"\n  ... and {len(problems) - 20} more" if len(problems) > 20 else ""
        raise RuntimeError(f"the built site loads from other hosts or holds builder paths:\n  {shown}{more}")
