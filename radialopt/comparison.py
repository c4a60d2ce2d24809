"""Solver comparison on seeded radial projection problems (library side of examples/05).

:func:`benchmark_problems` builds a seeded set of projection problems (n = 3..8 spheres,
feasible and infeasible, well and badly scaled); :func:`compare_solvers` runs every method
and every installed cvxpy solver on them and :func:`summarize` reports, per solver, the
success rate (status ``"optimal"`` within tolerance), the ``optimal_inaccurate`` rate in its
own column (never counted as success), median and p95 time, the largest constraint
violation, the largest distance to the exact answer and the shifted geometric mean of time,
the way public QP benchmarks (qpbenchmark) report it.  Runs go to local processes by
default, or to a Dask distributed cluster given its address.
"""

from __future__ import annotations

import csv
import io
import math
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass
from typing import Any, Literal, get_args

import numpy as np

from ._projection_types import _Problem
from .errors import RadialArgumentError, RadialError
from .projection import RadialStatus, installed_cvxpy_solvers, project_radii
from .spheres import TOLERANCES, GaussianSphere, make_spheres
from .tolerances import COMPARISON_VIOLATION

#: cvxpy solvers that accept a convex QP; others (LP-only, mixed-integer) are left out.
QP_CAPABLE = ("CLARABEL", "OSQP", "SCS", "ECOS", "HIGHS", "PIQP", "PROXQP", "QOCO", "CVXOPT",
              "MOSEK", "GUROBI", "CPLEX", "XPRESS", "COPT", "DAQP")

#: Shift (seconds) of the shifted geometric mean of solve time.
TIME_SHIFT = 1e-3


@dataclass(frozen=True)
class Problem:
    """One projection problem: its spheres and labels."""

    name: str
    n: int
    feasible: bool
    scaling: str
    centers: np.ndarray
    radii: np.ndarray
    sigmas: np.ndarray

    def spheres(self) -> list[GaussianSphere]:
        """The problem's Gaussian spheres, one per centre."""
        return make_spheres(self.centers, self.radii, self.sigmas)


#: Status of a :class:`Run`: the solver's :data:`~radialopt.projection.RadialStatus`, or
#: ``"skipped"`` when the solver is not installed.
RunStatus = Literal[RadialStatus, "skipped"]
RUN_STATUSES: tuple[str, ...] = get_args(RunStatus)


@dataclass(frozen=True)
class Run:
    """The outcome of one solver on one problem."""

    solver: str
    problem: str
    n: int
    feasible: bool
    scaling: str
    success: bool
    status: RunStatus
    time: float
    violation: float
    distance: float
    message: str = ""

    @property
    def inaccurate(self) -> bool:
        """The solver answered but only to its reduced accuracy (never a success)."""
        return self.status == "optimal_inaccurate"


def benchmark_problems(
    rng: np.random.Generator, per_case: int = 5, sizes: Iterable[int] = range(3, 9)
) -> list[Problem]:
    """Seeded problems: for every n, ``per_case`` of each (feasible | infeasible) x
    (well | badly scaled).  Badly scaled problems mix sigmas over five decades and put the
    landmarks 10^3 m from the origin."""
    out = []
    for n in sizes:
        for feasible in (True, False):
            for scaling in ("well", "bad"):
                k = 0
                while k < per_case:
                    centers = rng.uniform(-3, 3, size=(n, 3))
                    robot = rng.uniform(-3, 3, size=3)
                    rho = np.linalg.norm(centers - robot, axis=1)
                    if scaling == "well":
                        # eq. 6 (perception.depth_sigma(rho, 50.0, min_sigma=1e-3)), written out:
                        # radialopt, the bottom layer, imports neither perception nor worldgraph
                        sig = np.maximum(rho**2 / 50.0, 1e-3)
                    else:
                        sig = 10.0 ** rng.uniform(-4, 1, size=n)
                        offset = rng.uniform(-1e3, 1e3, size=3)
                        centers = centers + offset
                    noise = (0.0 if feasible else 3.0) * sig * rng.standard_normal(n)
                    radii = np.abs(rho + noise)
                    spheres = make_spheres(centers, radii, sig)
                    p = _Problem.build(spheres, TOLERANCES)
                    if (p.h.min() >= 0) != feasible:
                        continue
                    out.append(Problem(f"n{n}-{'feas' if feasible else 'infeas'}-{scaling}-{k}",
                                       n, feasible, scaling, centers, radii, sig))
                    k += 1
    return out


#: :class:`~radialopt.formulation.RadialProblem` objectives run (with Clarabel) as
#: ``"formulation:OBJECTIVE"``; l1 and Huber minimise another objective, so their distance to
#: the exact (l2) answer measures how differently they treat the ranges, not an error.
FORMULATIONS = ("l2", "l1", "huber")


def available_solvers(include_cvxpy: bool = True) -> list[str]:
    """Names accepted by :func:`solve_with`: our methods, then the installed QP-capable
    cvxpy solvers as ``"cvxpy:NAME"``, then the RadialProblem objectives as
    ``"formulation:OBJECTIVE"`` (Clarabel)."""
    names = ["active_set", "vertices", "paper"]
    if include_cvxpy:
        names += [f"cvxpy:{s}" for s in installed_cvxpy_solvers() if s in QP_CAPABLE]
        if "CLARABEL" in installed_cvxpy_solvers():
            names += [f"formulation:{o}" for o in FORMULATIONS]
    return names


_FORMULATION_CACHE: dict[tuple[str, int], object] = {}


def _formulation(objective: str, n: int):  # noqa: ANN202 - RadialProblem
    """One RadialProblem per (objective, n) and process: compiled once, re-used."""
    from .formulation import RadialProblem

    key = (objective, n)
    if key not in _FORMULATION_CACHE:
        _FORMULATION_CACHE[key] = RadialProblem(n, objective=objective)
    return _FORMULATION_CACHE[key]


def _known(name: str) -> bool:
    return (name in ("active_set", "vertices", "paper") or name.startswith("cvxpy:")
            or (name.startswith("formulation:") and name.split(":", 1)[1] in FORMULATIONS))


def solve_with(name: str, spheres: Sequence[GaussianSphere]):  # noqa: ANN201
    """Run one named solver (see :func:`available_solvers`); returns a RadialSolution."""
    if name.startswith("cvxpy:"):
        return project_radii(spheres, method="cvxpy", solver=name.split(":", 1)[1])
    if name.startswith("formulation:") and name.split(":", 1)[1] in FORMULATIONS:
        return _formulation(name.split(":", 1)[1], len(spheres)).solve(spheres, solver="CLARABEL")
    if name in ("active_set", "vertices", "paper"):
        return project_radii(spheres, method=name)
    raise RadialArgumentError(f"unknown solver {name!r}; choose from {available_solvers()}")


def run_one(solver: str, problem: Problem, max_vertices_n: int = 6) -> Run:
    """Solve one problem with one solver and measure it against the exact answer."""
    spheres = problem.spheres()
    base: dict[str, Any] = dict(solver=solver, problem=problem.name, n=problem.n, feasible=problem.feasible,
                scaling=problem.scaling)
    if solver == "vertices" and problem.n > max_vertices_n:
        return Run(**base, success=False, status="skipped", time=math.nan, violation=math.nan,
                   distance=math.nan, message=f"n > {max_vertices_n}")
    exact = project_radii(spheres, method="active_set")
    p = _Problem.build(spheres, TOLERANCES)
    try:
        t0 = time.perf_counter()
        sol = solve_with(solver, spheres)
        elapsed = time.perf_counter() - t0
    except RadialError as exc:
        return Run(**base, success=False, status="error", time=math.nan, violation=math.nan,
                   distance=math.nan, message=str(exc)[:200])
    violation = float(max(0.0, np.max(p.G @ ((sol.radii - p.radii) / p.sigmas) - p.h)))
    distance = float(np.max(np.abs(sol.radii - exact.radii)))
    # optimal_inaccurate is reported in its own column, never as a success
    success = sol.status == "optimal" and violation <= COMPARISON_VIOLATION
    return Run(**base, success=success, status=sol.status, time=elapsed, violation=violation,
               distance=distance)


def _run_batch(args: tuple[str, list[Problem]]) -> list[Run]:
    """Solve a batch with one solver, after one untimed warm-up solve per sphere count (so the
    cached cvxpy problems are compiled before timing, in every worker process)."""
    solver, problems = args
    seen = set()
    for p in problems:
        if p.n not in seen:
            seen.add(p.n)
            try:
                solve_with(solver, p.spheres())
            except RadialError:
                pass
    return [run_one(solver, p) for p in problems]


def compare_solvers(
    problems: Sequence[Problem],
    solvers: Sequence[str] | None = None,
    workers: int | None = None,
    scheduler_address: str | None = None,
    progress: bool | Callable[[int, int], None] = False,
    chunk: int = 20,
) -> list[Run]:
    """Run every solver on every problem.

    Parameters
    ----------
    problems : sequence of Problem
        From :func:`benchmark_problems`.
    solvers : sequence of str, optional
        Names from :func:`available_solvers` (default: all).
    workers : int, optional
        Local worker processes (default: one per core; 1 runs in this process, which gives
        the cleanest timings).
    scheduler_address : str, optional
        Address of a Dask distributed scheduler (``"tcp://host:8786"``); the work is then
        submitted there instead of to local processes.  Needs ``pip install distributed``.
    progress : bool or callable
        True shows a tqdm progress bar (``pip install tqdm``); a callable receives
        ``(done, total)`` after each finished batch.
    chunk : int
        Problems per submitted task.

    Returns
    -------
    list of Run, ordered by solver then problem (independent of scheduling).
    """
    names = list(solvers) if solvers is not None else available_solvers()
    for s in names:
        if not _known(s):
            raise RadialArgumentError(f"unknown solver {s!r}; choose from {available_solvers()}")
    tasks = [(s, list(problems[i:i + chunk])) for s in names for i in range(0, len(problems), chunk)]
    report = _progress_reporter(progress, len(tasks))
    results: list[list[Run]] = [[] for _ in tasks]
    if scheduler_address is not None:
        try:
            from distributed import Client, as_completed
        except ImportError as exc:
            raise RadialArgumentError(
                "scheduler_address needs Dask distributed: pip install distributed") from exc
        with Client(scheduler_address) as client:
            futures = {client.submit(_run_batch, t, pure=False): i for i, t in enumerate(tasks)}
            for done, fut in enumerate(as_completed(futures), 1):
                results[futures[fut]] = fut.result()
                report(done)
    elif workers == 1:
        for i, t in enumerate(tasks):
            results[i] = _run_batch(t)
            report(i + 1)
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            for i, batch in enumerate(pool.map(_run_batch, tasks)):
                results[i] = batch
                report(i + 1)
    report(None)
    return [run for batch in results for run in batch]


def _progress_reporter(progress: bool | Callable[[int, int], None], total: int):  # noqa: ANN202
    if callable(progress):
        return lambda done: None if done is None else progress(done, total)
    if not progress:
        return lambda done: None
    try:
        from tqdm import tqdm
    except ImportError as exc:
        raise RadialArgumentError("progress=True needs tqdm: pip install tqdm") from exc
    bar = tqdm(total=total, unit="batch")

    def update(done: int | None) -> None:
        if done is None:
            bar.close()
        else:
            bar.update(done - bar.n)

    return update


def shifted_geometric_mean(values: Sequence[float], shift: float = TIME_SHIFT) -> float:
    """``exp(mean(log(v + shift))) - shift``: a time average that neither one slow outlier
    nor many near-zero times dominate."""
    v = np.asarray(values, dtype=float)
    return float(np.exp(np.mean(np.log(v + shift))) - shift)


@dataclass(frozen=True)
class Summary:
    """Per-solver statistics over all its runs."""

    solver: str
    runs: int
    success_rate: float
    median_time: float
    p95_time: float
    max_violation: float
    max_distance: float
    shifted_gmean_time: float
    inaccurate_rate: float = 0.0


def summarize(runs: Sequence[Run], timeout: float = 1.0) -> list[Summary]:
    """Summaries per solver; failed runs count as ``timeout`` seconds in the shifted mean
    (qpbenchmark's convention), and are left out of the median/p95 and accuracy columns."""
    out = []
    for solver in dict.fromkeys(r.solver for r in runs):
        rs = [r for r in runs if r.solver == solver and r.status != "skipped"]
        if not rs:
            continue
        ok = [r for r in rs if r.success]
        times = [r.time for r in ok]
        out.append(Summary(
            solver=solver,
            runs=len(rs),
            success_rate=len(ok) / len(rs),
            median_time=float(np.median(times)) if times else math.nan,
            p95_time=float(np.percentile(times, 95)) if times else math.nan,
            max_violation=max((r.violation for r in ok), default=math.nan),
            max_distance=max((r.distance for r in ok), default=math.nan),
            shifted_gmean_time=shifted_geometric_mean(
                [r.time if r.success else timeout for r in rs]),
            inaccurate_rate=sum(r.inaccurate for r in rs) / len(rs),
        ))
    return out


def markdown_table(summaries: Sequence[Summary]) -> str:
    """The summaries as a Markdown table; the shifted geometric mean is also given relative
    to the fastest solver (1.0 = fastest)."""
    best = min((s.shifted_gmean_time for s in summaries), default=1.0)
    lines = [
        "| solver | runs | success | optimal_inaccurate | median time | p95 time | "
        "max violation (m) | max distance to exact (m) | shifted gmean time | relative |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for s in summaries:
        lines.append(
            f"| {s.solver} | {s.runs} | {100 * s.success_rate:.1f}% | "
            f"{100 * s.inaccurate_rate:.1f}% | {_fmt_time(s.median_time)} | "
            f"{_fmt_time(s.p95_time)} | {s.max_violation:.1e} | {s.max_distance:.1e} | "
            f"{_fmt_time(s.shifted_gmean_time)} | {s.shifted_gmean_time / best:.1f} |"
        )
    return "\n".join(lines)


def runs_csv(runs: Sequence[Run]) -> str:
    """All runs as CSV text (one row per solver and problem)."""
    buf = io.StringIO()
    fields = list(Run.__dataclass_fields__)
    writer = csv.DictWriter(buf, fieldnames=fields)
    writer.writeheader()
    for r in runs:
        writer.writerow(asdict(r))
    return buf.getvalue()


def _fmt_time(t: float) -> str:
    if not math.isfinite(t):
        return "-"
    if t < 1e-3:
        return f"{t * 1e6:.0f} µs"
    if t < 1:
        return f"{t * 1e3:.2f} ms"
    return f"{t:.2f} s"
