"""Solver comparison: the library function behind examples/05_compare_solvers.py."""

import csv
import dataclasses
import io
import math

import numpy as np
import pytest

from radialopt.comparison import (
    Run,
    available_solvers,
    benchmark_problems,
    compare_solvers,
    markdown_table,
    runs_csv,
    shifted_geometric_mean,
    summarize,
)
from radialopt.errors import RadialError


@pytest.fixture(scope="module")
def problems():
    return benchmark_problems(np.random.default_rng(7), per_case=1, sizes=[3, 4])


def test_problem_set_covers_every_case(problems):
    cases = {(p.n, p.feasible, p.scaling) for p in problems}
    assert cases == {(n, f, s) for n in (3, 4) for f in (True, False) for s in ("well", "bad")}
    assert len({p.name for p in problems}) == len(problems)


def test_at_least_five_solvers_are_available():
    names = available_solvers()
    assert {"active_set", "vertices", "paper", "cvxpy:CLARABEL"} <= set(names)
    assert len(names) >= 5


def test_serial_and_parallel_runs_agree(problems):
    solvers = ["active_set", "paper", "cvxpy:CLARABEL"]
    serial = compare_solvers(problems, solvers, workers=1, chunk=3)
    parallel = compare_solvers(problems, solvers, workers=2, chunk=3)
    assert [(r.solver, r.problem) for r in serial] == [(r.solver, r.problem) for r in parallel]
    for a, b in zip(serial, parallel, strict=True):
        assert a.success == b.success
        assert a.distance == pytest.approx(b.distance, abs=1e-9)
    exact = [r for r in serial if r.solver == "active_set"]
    assert all(r.success and r.distance == 0.0 for r in exact)
    clarabel = [r for r in serial if r.solver == "cvxpy:CLARABEL"]
    assert all(r.success and r.distance < 1e-6 for r in clarabel)


def test_dask_cluster_path_gives_the_same_runs(problems):
    import distributed  # in the test extras

    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        runs = compare_solvers(problems[:4], ["active_set", "paper"],
                               scheduler_address=cluster.scheduler_address, chunk=2)
    local = compare_solvers(problems[:4], ["active_set", "paper"], workers=1, chunk=2)
    assert [(r.solver, r.problem, r.success) for r in runs] == \
        [(r.solver, r.problem, r.success) for r in local]


def test_progress_callback_sees_every_batch(problems):
    seen = []
    compare_solvers(problems, ["active_set"], workers=1, chunk=2,
                    progress=lambda done, total: seen.append((done, total)))
    total = math.ceil(len(problems) / 2)
    assert seen[-1] == (total, total) and len(seen) == total


def test_summary_statistics_by_hand():
    def run(solver, t, ok=True, dist=0.0):
        return Run(solver, "p", 3, True, "well", ok, "optimal" if ok else "error", t, 0.0, dist)

    runs = [run("a", 1e-3), run("a", 3e-3), run("a", 2e-3, dist=1e-9), run("a", math.nan, False)]
    (s,) = summarize(runs, timeout=1.0)
    assert s.runs == 4 and s.success_rate == 0.75
    assert s.median_time == pytest.approx(2e-3)
    assert s.max_distance == 1e-9
    expected = math.exp((math.log(2e-3) + math.log(4e-3) + math.log(3e-3) + math.log(1.001)) / 4)
    assert s.shifted_gmean_time == pytest.approx(expected - 1e-3)
    assert shifted_geometric_mean([5.0, 5.0], shift=1.0) == pytest.approx(5.0)


def test_markdown_and_csv_outputs(problems):
    runs = compare_solvers(problems[:2], ["active_set", "paper"], workers=1)
    table = markdown_table(summarize(runs))
    assert table.count("\n") == 3 and "| active_set |" in table and "| paper |" in table
    rows = list(csv.DictReader(io.StringIO(runs_csv(runs))))
    assert len(rows) == len(runs) and rows[0]["solver"] == "active_set"


def test_optimal_inaccurate_has_its_own_column_and_is_never_success():
    def run(status, ok):
        return Run("s", "p", 3, True, "well", ok, status, 1e-3, 0.0, 0.0)

    runs = [run("optimal", True), run("optimal_inaccurate", False), run("optimal", True),
            run("error", False)]
    (s,) = summarize(runs)
    assert s.success_rate == 0.5 and s.inaccurate_rate == 0.25
    table = markdown_table([s])
    assert "| optimal_inaccurate |" in table.splitlines()[0]
    assert "| 50.0% | 25.0% |" in table


def test_runs_count_optimal_inaccurate_apart_from_success(problems, monkeypatch):
    import radialopt.comparison as cmp

    real = cmp.solve_with

    def degraded(name, spheres):
        sol = real(name, spheres)
        return dataclasses.replace(sol, status="optimal_inaccurate")

    monkeypatch.setattr(cmp, "solve_with", degraded)
    runs = compare_solvers(problems[:3], ["cvxpy:CLARABEL"], workers=1)
    assert all(r.inaccurate and not r.success for r in runs)
    assert summarize(runs)[0].inaccurate_rate == 1.0


def test_formulation_rows_run_and_l2_matches_exact(problems):
    names = available_solvers()
    assert {"formulation:l2", "formulation:l1", "formulation:huber"} <= set(names)
    runs = compare_solvers(problems, ["formulation:l2", "formulation:l1", "formulation:huber"],
                           workers=1)
    assert all(r.success for r in runs)
    assert all(r.distance < 1e-6 for r in runs if r.solver == "formulation:l2")
    table = markdown_table(summarize(runs))
    assert "| formulation:huber |" in table


def test_unknown_solver_is_rejected(problems):
    with pytest.raises(RadialError, match=r"unknown solver 'nope'"):
        compare_solvers(problems, ["nope"])
    with pytest.raises(RadialError, match=r"unknown solver 'formulation:l3'"):
        compare_solvers(problems, ["formulation:l3"])
