"""
Compare every installed solver on seeded radial projection problems
===================================================================

Run it from the repository root::

    python examples/05_compare_solvers.py [--per-case 5] [--workers N] [--scheduler tcp://host:8786]

Problems: n = 3..8 spheres, feasible and infeasible, well and badly scaled.  Solvers: the
active-set fast path, vertex enumeration in V-form (n <= 6), the paper's eq. 17, and every
installed QP-capable cvxpy solver (Clarabel, OSQP, SCS, ECOS, HiGHS, ...), and the
RadialProblem objectives (l2, l1, Huber) with Clarabel.  "success" counts only status
"optimal" within tolerance; "optimal_inaccurate" has its own column.  Prints a Markdown
table and writes it with a CSV of every run and a bar chart of the solve times
(``05_compare_solvers.png``) into --out.  Runs in local processes by default; with
--scheduler they go to a Dask distributed cluster instead.  Timing columns are cleanest with
--workers 1.

Needs only the ``examples`` extra: the cvxpy solvers of the ``solvers`` extra (OSQP, SCS, ECOS,
HiGHS) that are not installed are skipped with a note, and without tqdm there is no progress
bar.  The solvers' own console output (HiGHS' banner, cvxpy's "Solution may be inaccurate"
warning) is silenced; inaccurate answers have their own column in the table.
"""

from __future__ import annotations

import contextlib
import os
import sys
import warnings

import numpy as np
from _common import parse_args_with, pyplot

from radialopt.comparison import (
    available_solvers,
    benchmark_problems,
    compare_solvers,
    markdown_table,
    runs_csv,
    summarize,
)

#: The cvxpy solvers of the ``solvers`` extra (pip install gaussian-spheres[solvers]).
EXTRA_SOLVERS = ("OSQP", "SCS", "ECOS", "HIGHS")
#: cvxpy's warning for an optimal_inaccurate answer, which the table counts in its own column.
INACCURATE_WARNING = "Solution may be inaccurate"


@contextlib.contextmanager
def quiet_stdout():
    """Send file descriptor 1 to /dev/null: HiGHS prints its banner from C, past sys.stdout,
    once per process (worker processes inherit the redirection)."""
    sys.stdout.flush()
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


def save_figure(path, summaries, n_problems: int) -> None:
    """Horizontal bars of each solver's shifted geometric mean solve time (failures count as
    1 s), coloured by family, with the success rate at the end of each bar."""
    plt = pyplot()
    families = {"ours": ("tab:blue", "radialopt's own methods"),
                "cvxpy": ("tab:orange", "cvxpy backends"),
                "formulation": ("tab:green", "RadialProblem objectives (Clarabel)")}
    fig, ax = plt.subplots(figsize=(9, 0.45 * len(summaries) + 1.6), constrained_layout=True)
    y = np.arange(len(summaries))[::-1]
    for yi, s in zip(y, summaries, strict=True):
        family = s.solver.split(":", 1)[0] if ":" in s.solver else "ours"
        colour, label = families[family]
        ax.barh(yi, 1e3 * s.shifted_gmean_time, color=colour, label=label)
        ax.text(1e3 * s.shifted_gmean_time * 1.08, yi, f"{100 * s.success_rate:.0f}% solved",
                va="center", fontsize=8)
    ax.set_yticks(y, [s.solver for s in summaries])
    ax.set_xscale("log")
    fastest = min(1e3 * s.shifted_gmean_time for s in summaries)
    ax.set_xlim(fastest / 3, ax.get_xlim()[1] * 4)  # room for the success labels
    ax.set_xlabel("shifted geometric mean solve time (ms, log scale; a failure counts as 1 s)")
    ax.set_title(f"radial projection: {n_problems} seeded problems per solver")
    handles, labels = ax.get_legend_handles_labels()
    unique = dict(zip(labels, handles, strict=True))
    ax.legend(unique.values(), unique.keys(), loc="upper left",
              bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, frameon=False, fontsize=8)
    fig.savefig(path, dpi=90, bbox_inches="tight")


def main() -> None:
    args = parse_args_with(__doc__, [
        ("--per-case", {"type": int, "default": 5, "help": "problems per (n, feasible, scaling)"}),
        ("--workers", {"type": int, "default": None, "help": "local processes (default: cores)"}),
        ("--scheduler", {"default": None, "help": "Dask scheduler address"}),
        ("--no-progress", {"action": "store_true"}),
    ])
    per_case = 1 if args.smoke else args.per_case
    sizes = range(3, 6) if args.smoke else range(3, 9)
    problems = benchmark_problems(np.random.default_rng(args.seed), per_case, sizes)
    solvers = available_solvers()
    missing = [name for name in EXTRA_SOLVERS if f"cvxpy:{name}" not in solvers]
    if missing:
        print(f"note: {', '.join(missing)} not installed, skipped "
              "(pip install gaussian-spheres[solvers] adds them)")
    progress = not args.no_progress
    if progress:
        try:
            import tqdm  # noqa: F401 - only asked whether it is there
        except ImportError:
            print("note: no progress bar without tqdm (pip install tqdm)")
            progress = False
    print(f"{len(problems)} problems x {len(solvers)} solvers: {', '.join(solvers)}")
    # worker processes see the filter through the environment (fork or spawn alike)
    os.environ["PYTHONWARNINGS"] = f"ignore:{INACCURATE_WARNING}:UserWarning"
    with warnings.catch_warnings(), quiet_stdout():
        warnings.filterwarnings("ignore", message=INACCURATE_WARNING, category=UserWarning)
        runs = compare_solvers(problems, solvers, workers=args.workers,
                               scheduler_address=args.scheduler, progress=progress)
    summaries = summarize(runs)
    table = markdown_table(summaries)
    print(table)
    (args.out / "solver_comparison.md").write_text(table + "\n")
    (args.out / "solver_comparison.csv").write_text(runs_csv(runs))
    save_figure(args.out / "05_compare_solvers.png", summaries, len(problems))
    print(f"saved {args.out / 'solver_comparison.md'}, {args.out / 'solver_comparison.csv'} and "
          f"{args.out / '05_compare_solvers.png'}")


if __name__ == "__main__":
    main()
