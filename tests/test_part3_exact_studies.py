"""Part III's studies against exact answers and the coding exercises of chapters 20 and 22.

The stored study ``count_resampling`` runs on the Part III capstone's model: its data and exact means must
be the capstone's (``pfcourse.book.exercises.count_data`` and ``count_grid``), and its filter must
converge to them. Its stored rows, and those of ``linear_n``, are re-computed by
``tests/test_stored_studies.py`` like every registered study's; here a few rows are re-computed too.
"""

import numpy as np
import pytest

from pfcourse.book.exercises import (RATIO_CASE, RATIO_MISTAKES, TIME_TO_LOCK_MISTAKES, CountModel,
                                     check_mse_ratio, check_time_to_lock, count_data, count_grid,
                                     mse_ratio_reference, time_to_lock_cases, time_to_lock_reference)
from pfcourse.errors import ParameterError
from pfcourse.metrics import locked_on
from pfcourse.studies import count_resampling as cr
from pfcourse.studies.registry import STUDIES


def test_the_study_uses_the_capstones_data_and_exact_means():
    y = count_data()
    assert np.array_equal(cr.count_data(), y)
    assert np.array_equal(cr.exact_means(y), count_grid(y, CountModel()))


def test_the_filter_converges_to_the_exact_means():
    """At the Monte Carlo rate: 16 times the particles divide the RMS error by about 4 (the median over
    runs, so by 2.5 to 6.5)."""
    y, exact = cr.count_data(), cr.exact_means(cr.count_data())
    err = {n: np.median([np.sqrt(np.mean((cr.bootstrap_means(y, n, 0.5, "systematic",
                                                               np.random.default_rng(r))[0] - exact) ** 2))
                         for r in range(12)]) for n in (100, 1600)}
    assert 2.5 < err[100] / err[1600] < 6.5, err


def test_thresholds_resample_as_the_rule_says():
    y = cr.count_data()
    counts = [cr.bootstrap_means(y, 100, tau, "systematic", np.random.default_rng(0))[1] for tau in (0.0, 0.5, 1.0)]
    assert counts[0] == 0 and 0 < counts[1] < len(y) and counts[2] == len(y)
    with pytest.raises(ParameterError):
        cr.bootstrap_means(y, 100, 1.5, "systematic", np.random.default_rng(0))


@pytest.mark.parametrize("name", ["count_resampling", "linear_n"])
def test_stored_rows_are_recomputed(name):
    study = STUDIES[name]
    table = study.load()
    assert len(table) == len(study.layout())
    rows = table[study.cheap(table)] if study.cheap else table
    for _, stored in rows.iloc[[0, len(rows) // 2, -1]].iterrows():
        again = study.recompute(stored)
        for key, value in again.items():
            assert value == stored[key], (name, key)


# --- exercise 20.1: the ratio of mean squared errors and its bootstrap interval -----------------------------------------------
def test_the_reference_ratio_passes_on_many_seeds():
    assert all(check_mse_ratio(lambda a, b, n, rng: mse_ratio_reference(a, b, n, rng), seed=s).ok for s in range(10))


@pytest.mark.parametrize("mistake", list(RATIO_MISTAKES))
def test_each_ratio_mistake_is_named(mistake):
    report = check_mse_ratio(lambda a, b, n, rng: mse_ratio_reference(a, b, n, rng, mistake))
    assert report.problems == [f"your function computes a known mistake: {RATIO_MISTAKES[mistake]}"]


def test_the_ratio_mistakes_differ_on_the_case():
    """Each mistake moves the median or an end of the interval by more than twice the checker's tolerance."""
    from pfcourse.book.exercises.part3 import RATIO_TOL, WRONG_LEVELS

    a, b = RATIO_CASE
    ref = mse_ratio_reference(a, b, 40000, np.random.default_rng(1))
    for mistake, level in [(m, 0.9) for m in RATIO_MISTAKES] + [("wrong_level", v) for v in WRONG_LEVELS]:
        other = mse_ratio_reference(a, b, 40000, np.random.default_rng(1), mistake, level)
        assert (not np.isclose(other[0], ref[0])) or max(abs(other[1] - ref[1]), abs(other[2] - ref[2])) > \
            2 * RATIO_TOL * (ref[2] - ref[1]), mistake


def _bootstrap(a, b, n_boot, rng):
    rows = rng.integers(0, len(a), (n_boot, len(a)))
    ratios = np.mean(a[rows] ** 2, axis=1) / np.mean(b[rows] ** 2, axis=1)
    return (np.mean(a**2) / np.mean(b**2), *np.quantile(ratios, [0.025, 0.975]))


def test_the_ratio_generator_is_checked():
    def global_state(a, b, n, rng):
        return _bootstrap(a, b, n, np.random.default_rng(np.random.randint(1 << 30)))

    def own_generator(a, b, n, rng):
        return _bootstrap(a, b, n, np.random.default_rng())

    def fixed_seed(a, b, n, rng):
        return _bootstrap(a, b, n, np.random.default_rng(0))

    np.random.seed(3)
    expected = np.random.random()
    np.random.seed(3)
    assert check_mse_ratio(_bootstrap).ok
    assert np.random.random() == expected  # the checker leaves NumPy's global state as it was
    assert "global generator" in check_mse_ratio(global_state).problems[0]
    assert "same seed" in check_mse_ratio(own_generator).problems[0]
    assert "whatever the generator's seed" in check_mse_ratio(fixed_seed).problems[0]


def test_ratio_answers_of_the_wrong_form_are_named():
    assert "three numbers" in check_mse_ratio(lambda a, b, n, rng: 1.0).problems[0]
    assert "does not contain" in check_mse_ratio(lambda a, b, n, rng: (1.0, 1.2, 1.3)).problems[0]
    assert "returned None" in check_mse_ratio(lambda a, b, n, rng: None).problems[0]


# --- exercise 22.1: when a run locks on for good ---------------------------------------------------------------
def test_the_reference_time_to_lock_passes_and_agrees_with_locked_on():
    assert check_time_to_lock(time_to_lock_reference).ok
    for pos, head, dt in time_to_lock_cases():
        t0, end = time_to_lock_reference(pos, head, dt), len(pos) * dt
        for window in (5.0, 10.0, 20.0):
            # locked on over the last `window` seconds exactly when the run locks on for good before them
            assert locked_on(pos, head, dt, window) == (t0 is not None and t0 <= end - window + 1e-9), (t0, window)


@pytest.mark.parametrize("mistake", list(TIME_TO_LOCK_MISTAKES))
def test_each_time_to_lock_mistake_is_named(mistake):
    report = check_time_to_lock(lambda p, h, dt: time_to_lock_reference(p, h, dt, mistake))
    assert report.problems == [f"your function computes a known mistake: {TIME_TO_LOCK_MISTAKES[mistake]}"]


def test_an_unknown_time_to_lock_mistake_names_the_run():
    assert "run 1 " in check_time_to_lock(lambda p, h, dt: 0.0).problems[0]
    assert "None for every run" in check_time_to_lock(lambda p, h, dt: None).problems[0]
    assert "not a time" in check_time_to_lock(lambda p, h, dt: "soon").problems[0]
