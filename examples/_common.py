"""Helpers shared by the example scripts: output folder and command-line flags."""

from __future__ import annotations

import argparse
from pathlib import Path


def parse_args_with(doc: str | None, extra: list[tuple[str, dict]]) -> argparse.Namespace:
    """Common flags (--out, --seed, --smoke) plus ``extra`` (flag, add_argument kwargs); the help
    text is the title of the example's docstring ``doc`` (its first line that is not blank; none
    when the docstring is absent, as when the documentation's gallery runs the example)."""
    title = next((line.strip() for line in (doc or "").splitlines() if line.strip()), "")
    ap = argparse.ArgumentParser(description=title)
    ap.add_argument("--out", type=Path, default=Path("out"), help="folder for figures")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--smoke", action="store_true", help="smaller, faster run (tests)")
    for flag, kwargs in extra:
        ap.add_argument(flag, **kwargs)
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    return args


def parse_args(doc: str | None) -> argparse.Namespace:
    """Only the common flags."""
    return parse_args_with(doc, [])


def pyplot():
    """matplotlib.pyplot with the non-interactive Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
