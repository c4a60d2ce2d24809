"""Compare every installed solver on seeded radial projection problems.

    python examples/05_compare_solvers.py [--per-case 5] [--workers N] [--scheduler tcp://host:8786]

Problems: n = 3..8 spheres, feasible and infeasible, well and badly scaled.  Solvers: the
active-set fast path, vertex enumeration in V-form (n <= 6), the paper's eq. 17, and every
installed QP-capable cvxpy solver (Clarabel, OSQP, SCS, ECOS, HiGHS, ...), and the
RadialProblem objectives (l2, l1, Huber) with Clarabel.  "success" counts only status
"optimal" within tolerance; "optimal_inaccurate" has its own column.  Prints a Markdown
table and writes it with a CSV of every run into --out.  Runs in local processes by default;
with --scheduler they go to a Dask distributed cluster instead.  Timing columns are cleanest
with --workers 1.
"""

from __future__ import annotations

import numpy as np
from _common import parse_args_with

from radialopt.comparison import (
    available_solvers,
    benchmark_problems,
    compare_solvers,
    markdown_table,
    runs_csv,
    summarize,
)


def main() -> None:
    args = parse_args_with(__doc__.splitlines()[0], [
        ("--per-case", {"type": int, "default": 5, "help": "problems per (n, feasible, scaling)"}),
        ("--workers", {"type": int, "default": None, "help": "local processes (default: cores)"}),
        ("--scheduler", {"default": None, "help": "Dask scheduler address"}),
        ("--no-progress", {"action": "store_true"}),
    ])
    per_case = 1 if args.smoke else args.per_case
    sizes = range(3, 6) if args.smoke else range(3, 9)
    problems = benchmark_problems(np.random.default_rng(args.seed), per_case, sizes)
    solvers = available_solvers()
    print(f"{len(problems)} problems x {len(solvers)} solvers: {', '.join(solvers)}")
    runs = compare_solvers(problems, solvers, workers=args.workers,
                           scheduler_address=args.scheduler, progress=not args.no_progress)
    table = markdown_table(summarize(runs))
    print(table)
    (args.out / "solver_comparison.md").write_text(table + "\n")
    (args.out / "solver_comparison.csv").write_text(runs_csv(runs))
    print(f"saved {args.out / 'solver_comparison.md'} and {args.out / 'solver_comparison.csv'}")


if __name__ == "__main__":
    main()
