"""The mistakes a new student made in Part III's coding exercises, as a student writes them: each gets its own
sentence, and the reference answers still pass (exercises 20.1 and 21.1)."""

import numpy as np
import pytest
from scipy.special import logsumexp

from pfcourse.book.exercises import (ADAPTIVE_MISTAKES, RATIO_MISTAKES, adaptive_residual, check_adaptive_residual,
                                     check_mse_ratio)
from pfcourse.book.exercises.part3 import EQUAL_CASE, RATIO_BOOT


def _ratio(percentiles):
    """A student's exercise 20.1 with the interval's ends at these percentiles."""
    def fn(a, b, n_boot, rng):
        a, b = np.asarray(a), np.asarray(b)
        rows = rng.integers(0, len(a), (n_boot, len(a)))
        boot = np.mean(a[rows] ** 2, axis=1) / np.mean(b[rows] ** 2, axis=1)
        return (np.mean(a**2) / np.mean(b**2), *np.percentile(boot, percentiles))
    return fn


@pytest.mark.parametrize("percentiles", [[10, 90], [5, 95], [0.5, 99.5]])
def test_a_wrong_confidence_level_is_named(percentiles):
    report = check_mse_ratio(_ratio(percentiles))
    assert report.problems == [f"your function computes a known mistake: {RATIO_MISTAKES['wrong_level']}"], report


def test_the_95_percent_interval_passes_on_many_seeds():
    """The tightened tolerance still accepts the reference whatever the seed of the checker's generator."""
    assert RATIO_BOOT >= 20000
    assert all(check_mse_ratio(_ratio([2.5, 97.5]), seed=s).ok for s in range(20))


def _students_residual(particles, log_w, tau, rng, shift=True, strict=True):
    """Exercise 21.1 as a student writes it; shift=False exponentiates the raw log-weights, strict=False
    resamples when ESS <= tau N."""
    n = len(log_w)
    if shift:
        w = np.exp(log_w - logsumexp(log_w))
    else:
        w = np.exp(log_w)
        w = w / w.sum()
    ess = 1.0 / np.sum(w**2)
    if (ess >= tau * n) if strict else (ess > tau * n):
        return particles, log_w
    counts = np.floor(n * w).astype(int)
    rest = n - counts.sum()
    if rest > 0:
        residual = n * w - counts
        counts += np.bincount(rng.choice(n, size=rest, p=residual / residual.sum()), minlength=n)
    return particles[np.repeat(np.arange(n), counts)], np.full(n, -np.log(n))


def test_the_students_residual_passes():
    assert check_adaptive_residual(_students_residual).ok


def test_weights_that_overflow_are_named():
    report = check_adaptive_residual(lambda p, lw, tau, rng: _students_residual(p, lw, tau, rng, shift=False))
    assert report.problems == [ADAPTIVE_MISTAKES["overflow"]], report


def test_a_rule_that_keeps_overflowing_clouds_is_named_too():
    """With ``ess < tau N`` written as the test to resample, NaN weights keep every cloud: the same mistake."""
    def keeps(p, lw, tau, rng):
        w = np.exp(lw) / np.sum(np.exp(lw))
        if not 1.0 / np.sum(w**2) < tau * len(lw):
            return p, lw
        return _students_residual(p, lw, tau, rng)
    with np.errstate(all="ignore"):
        assert check_adaptive_residual(keeps).problems == [ADAPTIVE_MISTAKES["overflow"]]


def test_resampling_equal_weights_is_named():
    report = check_adaptive_residual(lambda p, lw, tau, rng: _students_residual(p, lw, tau, rng, strict=False))
    assert report.problems == [ADAPTIVE_MISTAKES["not_strict"]], report


def test_equal_weights_give_an_ess_of_exactly_n_however_computed():
    log_w, tau = EQUAL_CASE
    n = len(log_w)
    by_logsumexp = np.exp(log_w - logsumexp(log_w))
    by_max = np.exp(log_w - log_w.max()) / np.sum(np.exp(log_w - log_w.max()))
    for w in (by_logsumexp, by_max):
        assert 1.0 / np.sum(w**2) == n == tau * n and np.sum(w) ** 2 / np.sum(w**2) == n


def test_the_reference_keeps_equal_weights():
    log_w, tau = EQUAL_CASE
    parts, new_w = adaptive_residual(np.arange(16.0), log_w, tau, np.random.default_rng(0))
    assert np.array_equal(parts, np.arange(16.0)) and np.array_equal(new_w, log_w)
