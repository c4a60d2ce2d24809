"""Lines of argument checking: the three ``_checks.py``, ``worldgraph/_rigid.py`` and the
three ``errors.py`` at one or more git revisions, as lines, code lines (no docstrings, comments or
blank lines) and the code lines' share of all code lines of the three packages.

Usage: ``python benchmarks/argument_checks.py [REV ...]`` (default ``HEAD``), from the repository.
"""

from __future__ import annotations

import ast
import io
import subprocess
import sys
import tokenize

PACKAGES = ("perception", "worldgraph", "radialopt")
CHECK_FILES = ("perception/_checks.py", "radialopt/_checks.py", "worldgraph/_checks.py",
               "worldgraph/_rigid.py", "perception/errors.py", "radialopt/errors.py", "worldgraph/errors.py")
SKIPPED_TOKENS = {tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT,
                  tokenize.ENDMARKER}


def _git(*args: str) -> str:
    return subprocess.run(["git", *args], capture_output=True, text=True, check=True).stdout


def code_lines(source: str) -> int:
    """Lines holding a token other than a comment, outside module, class and function docstrings."""
    docstrings: set[int] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) \
                    and isinstance(first.value.value, str):
                docstrings.update(range(first.lineno, (first.end_lineno or first.lineno) + 1))
    lines: set[int] = set()
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type not in SKIPPED_TOKENS:
            lines.update(n for n in range(tok.start[0], tok.end[0] + 1) if n not in docstrings)
    return len(lines)


def measure(rev: str) -> tuple[int, int, int]:
    """(lines, code lines) of the checking files and the code lines of all package modules."""
    lines = code = 0
    for path in CHECK_FILES:
        source = _git("show", f"{rev}:{path}")
        lines += len(source.splitlines())
        code += code_lines(source)
    files = [f for f in _git("ls-tree", "-r", "--name-only", rev).split()
             if f.endswith(".py") and f.split("/")[0] in PACKAGES]
    total = sum(code_lines(_git("show", f"{rev}:{f}")) for f in files)
    return lines, code, total


def main(revs: list[str]) -> None:
    print("| revision | lines | code lines | share of package code lines |")
    print("|---|---|---|---|")
    for rev in revs:
        lines, code, total = measure(rev)
        print(f"| {rev} | {lines:,} | {code:,} | {code / total:.1%} of {total:,} |")


if __name__ == "__main__":
    main(sys.argv[1:] or ["HEAD"])
