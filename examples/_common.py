"""Helpers shared by the example scripts: output folder and command-line flags."""

from __future__ import annotations

import argparse
from pathlib import Path


def parse_args_with(description: str, extra: list[tuple[str, dict]]) -> argparse.Namespace:
    """Common flags (--out, --seed, --smoke) plus ``extra`` (flag, add_argument kwargs)."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--out", type=Path, default=Path("out"), help="folder for figures")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--smoke", action="store_true", help="smaller, faster run (tests)")
    for flag, kwargs in extra:
        ap.add_argument(flag, **kwargs)
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    return args


def parse_args(description: str) -> argparse.Namespace:
    """Only the common flags."""
    return parse_args_with(description, [])


def pyplot():
    """matplotlib.pyplot with the non-interactive Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
