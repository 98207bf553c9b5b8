"""The Monte Carlo study runner: reproducible rows, common random numbers, failures recorded."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

from pfcourse import DegenerateWeightsError, ParameterError, ParticleFilter, kalman_filter
from pfcourse.scenarios.landmarks.scenario import quadrant_scenario, simulate
from pfcourse.studies.study import grid_settings, run_study, summarize
from pfcourse.seeding import replicate_seed


def landmark_run(seed: int, n_particles: int, threshold: float) -> dict:
    scenario = quadrant_scenario().with_(n_samples=10)
    sim = simulate(scenario, seed)
    model = scenario.model()
    result = ParticleFilter(model, n_particles, threshold=threshold).run(sim.measurements, rng=seed)
    kf = kalman_filter(model, sim.measurements)
    return {
        "rmse_vs_kalman": float(np.sqrt(np.mean((result.mean - kf.mean) ** 2))),
        "resamples": result.n_resamples,
        "truth_x0": float(sim.truth[0, 0]),
    }


def test_table_has_one_row_per_setting_and_run():
    table = run_study(landmark_run, {"n_particles": [50, 200], "threshold": [0.0, 0.5]}, 3, progress=False)
    assert len(table) == 2 * 2 * 3
    assert {"n_particles", "threshold", "run", "seed", "status", "error_message", "rmse_vs_kalman", "seconds"} <= set(table)
    assert (table["status"] == "ok").all()
    assert (table.loc[table["threshold"] == 0.0, "resamples"] == 0).all()


def test_each_row_is_reproducible_from_its_seed_alone():
    table = run_study(landmark_run, {"n_particles": [100], "threshold": [0.5]}, 4, base_seed=7, progress=False)
    row = table.iloc[2]
    assert row["seed"] == replicate_seed(7, 2)
    again = landmark_run(seed=int(row["seed"]), n_particles=100, threshold=0.5)
    assert again["rmse_vs_kalman"] == row["rmse_vs_kalman"]


def test_common_random_numbers_across_settings():
    table = run_study(landmark_run, {"n_particles": [50, 400], "threshold": [0.5]}, 5, progress=False)
    truths = table.pivot(index="run", columns="n_particles", values="truth_x0")
    np.testing.assert_array_equal(truths[50], truths[400])
    assert truths[50].nunique() == 5  # but different replicates see different truths


def test_a_collapse_is_recorded_and_the_study_goes_on():
    def fragile(seed: int, level: float) -> dict:
        if level > 1 and seed % 2 == 0:
            raise DegenerateWeightsError("step 4: every particle has zero likelihood", step=4)
        return {"error_m": level}

    table = run_study(fragile, {"level": [1.0, 2.0]}, 20, progress=False)
    failed = table[table["status"] == "failed"]
    assert len(failed) == int(sum(replicate_seed(0, r) % 2 == 0 for r in range(20)))
    assert (failed["level"] == 2.0).all() and failed["error_message"].str.contains("step 4").all()
    summary = summarize(table, "level", "error_m")
    assert summary.loc[1.0, "n_failed"] == 0 and summary.loc[2.0, "n_failed"] == len(failed)
    assert summary.loc[2.0, "n_ok"] + summary.loc[2.0, "n_failed"] == 20


def test_bugs_are_not_swallowed():
    def buggy(seed: int, level: float) -> dict:
        raise TypeError("a bug")

    with pytest.raises(TypeError, match="a bug"):
        run_study(buggy, {"level": [1.0]}, 2, progress=False)


def test_batches_give_the_same_rows_and_isolate_a_collapse():
    def one(seed: int, level: float) -> dict:
        if seed % 3 == 0:
            raise DegenerateWeightsError("collapse", step=1)
        return {"value": level * (seed % 1000)}

    def batch(seeds: list[int], level: float) -> list[dict]:
        return [one(seed, level) for seed in seeds]

    single = run_study(one, {"level": [1.0, 3.0]}, 12, progress=False)
    batched = run_study(None, {"level": [1.0, 3.0]}, 12, run_batch=batch, batch_size=5, progress=False)
    columns = ["level", "run", "seed", "status", "value"]
    assert single[columns].equals(batched[columns])


def test_summary_quantiles():
    table = run_study(lambda seed, a: {"m": float(seed % 101)}, {"a": [0]}, 50, progress=False)
    summary = summarize(table, "a", "m")
    values = table["m"].to_numpy()
    assert summary.loc[0, "q50"] == pytest.approx(np.quantile(values, 0.5))
    assert summary.loc[0, "q10"] <= summary.loc[0, "q50"] <= summary.loc[0, "q90"]


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"grid": {"a": []}}, r"grid\['a'\] must be a non-empty list"),
        ({"grid": {"a": "abc"}}, r"grid\['a'\] must be a non-empty list"),
        ({"grid": {"a": [1]}, "n_runs": 0}, "n_runs must be at least 1"),
        ({"grid": {"a": [1]}, "run_batch": lambda seeds, a: []}, "exactly one of run_one and run_batch"),
    ],
)
def test_bad_study_arguments(kwargs, message):
    kwargs = {"n_runs": 2, **kwargs}
    with pytest.raises(ParameterError, match=message):
        run_study(lambda seed, a: {}, progress=False, **kwargs)


def test_grid_order_last_key_fastest():
    assert grid_settings({"a": [1, 2], "b": ["x", "y"]}) == [
        {"a": 1, "b": "x"}, {"a": 1, "b": "y"}, {"a": 2, "b": "x"}, {"a": 2, "b": "y"}]


# --- executors: the same rows whatever runs them -------------------------------------------

def _robot_rows(executor) -> "pd.DataFrame":
    from functools import partial

    from pfcourse.studies.robot import pf_run

    table = run_study(partial(pf_run, n_steps=25, burn_in=5), {"n_particles": [30, 120]}, 6,
                      batch_size=4, progress=False, executor=executor)
    return table.drop(columns="seconds")


def test_rows_do_not_depend_on_the_executor_or_its_workers():
    from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

    from pfcourse.studies.executor import SerialExecutor

    serial = _robot_rows(SerialExecutor())
    assert len(serial) == 12 and (serial["status"] == "ok").all()
    for executor in (ProcessPoolExecutor(1), ProcessPoolExecutor(2), ThreadPoolExecutor(3)):
        with executor:
            assert _robot_rows(executor).equals(serial)
    assert _robot_rows(None).equals(serial)  # the default process pool


def test_a_dask_cluster_gives_the_same_rows():
    distributed = pytest.importorskip("distributed")
    from pfcourse.studies.executor import SerialExecutor

    serial = _robot_rows(SerialExecutor())
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None)
    with cluster, distributed.Client(cluster) as client:
        assert _robot_rows(client.get_executor()).equals(serial)


def test_executor_must_be_an_executor():
    with pytest.raises(ParameterError, match="executor must be"):
        run_study(lambda seed, a: {}, {"a": [1]}, 2, progress=False, executor="two cores")


def _blas_threads(_seed=None) -> list[int]:
    """Threads of each OpenBLAS loaded in this process."""
    from pfcourse.arithmetic import openblas_functions

    return [function() for _, function in openblas_functions("get_num_threads")]


def _set_blas_threads(n: int, paths: list[str] | None = None) -> None:
    import ctypes

    from pfcourse.arithmetic import openblas_functions

    for path, function in openblas_functions("set_num_threads"):
        if paths is None or path in paths:
            function.argtypes = [ctypes.c_int]
            function(n)


def test_pool_workers_run_one_blas_thread():
    """Forked workers must not inherit a BLAS thread per core (they would spin against each other)."""
    import scipy.linalg  # noqa: F401  (loads SciPy's OpenBLAS too)

    from pfcourse.studies.executor import default_executor

    executor, owned = default_executor(_blas_threads)
    if not owned:
        pytest.skip("one core or no fork: no pool")
    before = _blas_threads()
    _set_blas_threads(2)  # as in a notebook kernel: a BLAS thread per core
    try:
        assert all(c == 2 for c in _blas_threads())
        with executor:
            counts = executor.submit(_blas_threads).result()
    finally:
        from pfcourse.arithmetic import _openblas_libraries

        for path, n in zip(_openblas_libraries(), before):
            _set_blas_threads(n, [path])
    assert counts and all(c == 1 for c in counts), counts



def _hangs_in_a_worker(seed: int, a: int) -> dict:
    """A run that never answers in a pool worker (a deadlocked fork) and answers in the parent."""
    import multiprocessing
    import time as _time

    if multiprocessing.parent_process() is not None:
        _time.sleep(3600)
    return {"value": a * 1000 + seed % 997}


def _dies_in_a_worker(seed: int, a: int) -> dict:
    """A run whose worker process dies (a segfault, an OOM kill) and that answers in the parent."""
    import multiprocessing

    if multiprocessing.parent_process() is not None:
        os._exit(1)
    return {"value": a * 1000 + seed % 997}


@pytest.mark.parametrize("run_one, reason, stall_timeout",
                         [(_hangs_in_a_worker, "finished in", 2.0), (_dies_in_a_worker, "died", 30.0)])
def test_a_stuck_or_broken_pool_is_replaced_and_the_rows_are_unchanged(run_one, reason, stall_timeout):
    from pfcourse.studies.executor import SerialExecutor, StudyWarning, default_executor

    if not default_executor(run_one)[1]:
        pytest.skip("one core or no fork: no pool")
    grid = {"a": [1, 2]}
    serial = run_study(run_one, grid, 5, batch_size=2, progress=False, executor=SerialExecutor())
    start = time.perf_counter()
    with pytest.warns(StudyWarning, match=reason):
        pooled = run_study(run_one, grid, 5, batch_size=2, progress=False, stall_timeout=stall_timeout)
    assert time.perf_counter() - start < 60  # the stuck workers were stopped, not waited for
    assert pooled.drop(columns="seconds").equals(serial.drop(columns="seconds"))
    assert (pooled["status"] == "ok").all() and len(pooled) == 10


@pytest.mark.parametrize("value", [0, -1.0, float("nan"), "10"])
def test_stall_timeout_must_be_a_positive_number(value):
    with pytest.raises(ParameterError, match="stall_timeout"):
        run_study(lambda seed, a: {}, {"a": [1]}, 2, progress=False, stall_timeout=value)


def _slow_square(x: int) -> int:
    time.sleep(0.05 * (x % 3))  # finish out of order
    return x * x


def _refuses_three(x: int) -> int:
    if x == 3:
        raise ParameterError("three is refused")
    return x


def test_run_tasks_keeps_the_order_of_its_arguments_and_raises_a_task_error():
    from concurrent.futures import ThreadPoolExecutor

    from pfcourse.studies.executor import run_tasks

    seen = []
    with ThreadPoolExecutor(3) as pool:
        out = run_tasks(_slow_square, [(x,) for x in range(9)], executor=pool, on_result=seen.append)
    assert out == [x * x for x in range(9)]
    assert sorted(seen) == sorted(out)
    assert run_tasks(_slow_square, [(x,) for x in range(5)]) == [0, 1, 4, 9, 16]  # the default pool
    with pytest.raises(ParameterError, match="three is refused"):
        run_tasks(_refuses_three, [(x,) for x in range(5)])


def test_a_study_may_give_the_seeds_of_its_runs():
    table = run_study(lambda seed, a: {"x": seed * a}, {"a": [1, 2]}, 3, seeds=range(3), progress=False)
    assert list(table["seed"]) == [0, 1, 2, 0, 1, 2] and list(table["x"]) == [0, 1, 2, 0, 2, 4]
    with pytest.raises(ParameterError, match="one seed per run"):
        run_study(lambda seed: {}, {"a": [1]}, 3, seeds=[0, 1])


def test_medians_tabulates_each_metric_per_setting():
    import pandas as pd

    from pfcourse.book.figures.study_tables import medians

    table = pd.DataFrame({"n": [1, 1, 1, 2, 2, 2], "run": [0, 1, 2] * 2, "status": ["ok"] * 6,
                          "a": [1.0, 2.0, 9.0, 4.0, 5.0, 6.0], "b": [0.0, 0.0, 1.0, 3.0, 3.0, 3.0]})
    out = medians(table, "n", {"a": "A (m)", "b": "B"})
    assert list(out.columns) == ["n", "A (m)", "B"]
    assert list(out["A (m)"]) == [2.0, 5.0] and list(out["B"]) == [0.0, 3.0]


@pytest.mark.parametrize("batched", [False, True])
def test_a_collapsed_run_takes_the_studys_failed_scores(batched):
    def one(seed: int, level: float) -> dict:
        if seed % 2 == 0:
            raise DegenerateWeightsError("collapse", step=2)
        return {"error_m": level, "lost": False}

    def batch(seeds: list[int], level: float) -> list[dict]:
        return [one(seed, level) for seed in seeds]

    kwargs = {"run_batch": batch, "batch_size": 3} if batched else {"run_one": one}
    table = run_study(kwargs.pop("run_one", None), {"level": [1.0]}, 10, progress=False,
                      failed_scores={"error_m": np.inf, "lost": True}, **kwargs)
    failed = table["status"] == "failed"
    assert list(failed) == [s % 2 == 0 for s in table["seed"]] and failed.any() and (~failed).any()
    assert np.isinf(table.loc[failed, "error_m"]).all() and table.loc[failed, "lost"].all()
    assert (table.loc[~failed, "error_m"] == 1.0).all() and not table.loc[~failed, "lost"].any()
