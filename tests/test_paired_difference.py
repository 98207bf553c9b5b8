"""The interval of a difference of paired rates: consistent with the exact McNemar test, and its coverage.

``pfcourse.evidence.paired_difference_interval`` (used by ``paired_rates``) combines the
Clopper-Pearson interval of the share ``pi`` of discordant runs won by A with the Wilson interval of
the share ``psi`` of discordant runs. These tests check what its docstring derives: it covers 0
exactly when the exact McNemar test does not reject; its coverage over a grid of paired designs is at
least nominal (within the Monte Carlo error of the coverage estimate) and near nominal when many runs
differ; and its degenerate cases.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from scipy import stats

from pfcourse import evidence as ev

CONFIDENCE = 0.95


def paired_outcomes(both: int, only_a: int, only_b: int, neither: int) -> tuple[np.ndarray, np.ndarray]:
    """Boolean outcomes of runs under A and B with the given 2 x 2 table."""
    a = np.r_[np.ones(both + only_a, bool), np.zeros(only_b + neither, bool)]
    b = np.r_[np.ones(both, bool), np.zeros(only_a, bool), np.ones(only_b, bool), np.zeros(neither, bool)]
    return a, b


@pytest.mark.parametrize("n", [100])
def test_the_interval_covers_zero_exactly_when_mcnemar_does_not_reject(n):
    # every (b, c) with b + c <= 40 at n = 100, the rest of the runs split between "both" and "neither"
    checked = 0
    for b in range(41):
        for c in range(41 - b):
            a_runs, b_runs = paired_outcomes((n - b - c) // 2, b, c, n - b - c - (n - b - c) // 2)
            r = ev.paired_rates(a_runs, b_runs)
            assert (r.only_a, r.only_b) == (b, c)
            rejects = r.pvalue < 1 - CONFIDENCE
            covers_zero = r.difference_low <= 0.0 <= r.difference_high
            assert covers_zero == (not rejects), (b, c, r.pvalue, r.difference_low, r.difference_high)
            assert r.difference_low <= r.difference <= r.difference_high
            assert -1.0 <= r.difference_low and r.difference_high <= 1.0
            checked += 1
    assert checked == 41 * 42 // 2


def test_few_discordant_runs_leave_zero_inside_where_a_bootstrap_did_not():
    # 4 runs of 100 differ, all for A: exact p = 1/8; a percentile bootstrap gave (0.01, 0.08)
    r = ev.paired_rates(*paired_outcomes(50, 4, 0, 46))
    assert r.pvalue == pytest.approx(0.125)
    assert r.difference_low < 0 < r.difference_high
    # 2 of 100, both for A (p = 1/2): the interval reaches about as far below 0 as Wilson allows
    r2 = ev.paired_rates(*paired_outcomes(50, 2, 0, 48))
    assert r2.pvalue == pytest.approx(0.5)
    assert r2.difference_low < -0.01 and r2.difference_high > 0.05


def test_no_discordant_run_gives_plus_minus_the_wilson_bound_of_the_discordant_share():
    for n in (10, 100, 1000):
        r = ev.paired_rates(*paired_outcomes(n // 2, 0, 0, n - n // 2))
        upper = ev.rate(0, n).high  # Wilson upper bound of 0 of n (about 3.8 / n for n >= 100)
        assert r.pvalue == 1.0 and r.difference == 0.0
        assert (r.difference_low, r.difference_high) == pytest.approx((-upper, upper), abs=1e-15)
    # identical outcomes, all successes: the same
    ones = np.ones(50, bool)
    assert ev.paired_rates(ones, ones).difference_high == pytest.approx(ev.rate(0, 50).high)


def test_all_runs_discordant():
    n = 40
    # all for A: difference 1, upper limit 1, lower limit above 0 (p = 2^-39)
    r = ev.paired_rates(np.ones(n, bool), np.zeros(n, bool))
    assert r.difference == 1.0 and r.difference_high == 1.0
    assert 0.8 < r.difference_low < 1.0
    # split evenly: difference 0; every run differs (psi = 1), so the interval is that of 2 pi - 1
    r = ev.paired_rates(*paired_outcomes(0, n // 2, n // 2, 0))
    pi = stats.binomtest(n // 2, n).proportion_ci(method="exact")
    assert r.pvalue == 1.0
    # the psi term vanishes only at psi^ = psi_U = 1; psi_L < 1 adds a little on each side
    assert r.difference_low <= 2 * pi.low - 1 and r.difference_high >= 2 * pi.high - 1
    assert r.difference_high - r.difference_low < 2 * (pi.high - pi.low) + 0.05


@pytest.mark.parametrize("b,c,n", [(3, 9, 50), (0, 5, 100), (17, 2, 30), (0, 0, 7)])
def test_swapping_a_and_b_mirrors_the_interval(b, c, n):
    low, high = ev.paired_difference_interval(b, c, n)
    assert ev.paired_difference_interval(c, b, n) == pytest.approx((-high, -low), abs=1e-15)


def test_the_interval_lies_inside_the_box_of_its_two_intervals():
    # |L|, |U| <= (largest |tau| limit) x psi_U: never wider than the product of the two intervals
    for b, c, n in [(1, 0, 20), (12, 3, 60), (30, 31, 100), (5, 40, 300)]:
        low, high = ev.paired_difference_interval(b, c, n)
        psi_high = ev.rate(b + c, n).high
        assert -psi_high - 1e-15 <= low and high <= psi_high + 1e-15


def test_seed_is_accepted_and_changes_nothing():
    a, b = paired_outcomes(40, 7, 2, 51)
    assert ev.paired_rates(a, b, seed=0) == ev.paired_rates(a, b, seed=12345)


@pytest.mark.parametrize("args,match", [
    ((-1, 2, 10), "only_a"), ((3, 8, 10), "only_a \\+ only_b <= n"), ((1, 1, 0), "n=0"),
    ((1.5, 0, 10), "whole number"),
])
def test_bad_counts_are_named(args, match):
    with pytest.raises(ev.EvidenceError, match=match):
        ev.paired_difference_interval(*args)


# --- coverage by simulation ---------------------------------------------------------------------------

RATES = [(0.5, 0.5), (0.6, 0.5), (0.8, 0.5), (0.9, 0.6), (0.95, 0.9), (0.2, 0.05), (0.98, 0.98)]
CORRELATIONS = [0.0, 0.5, 0.8]
SIZES = [30, 100, 300]
N_TABLES = 2000  # simulated studies per design


def cells(p_a: float, p_b: float, rho: float) -> np.ndarray | None:
    """Probabilities of (both, only A, only B, neither) for rates p_a, p_b with outcome correlation rho."""
    p11 = p_a * p_b + rho * np.sqrt(p_a * (1 - p_a) * p_b * (1 - p_b))
    p = np.array([p11, p_a - p11, p_b - p11, 1 - p_a - p_b + p11])
    return p if np.all(p >= 0) else None


DESIGNS = [(pa, pb, rho, n) for n in SIZES for pa, pb in RATES for rho in CORRELATIONS
           if cells(pa, pb, rho) is not None]


@functools.lru_cache(maxsize=None)
def interval(b: int, c: int, n: int) -> tuple[float, float]:
    return ev.paired_difference_interval(b, c, n, CONFIDENCE)


def coverage(p_a: float, p_b: float, rho: float, n: int, seed: int) -> float:
    tables = np.random.default_rng(seed).multinomial(n, cells(p_a, p_b, rho), size=N_TABLES)
    delta = p_a - p_b
    hits = [lo - 1e-12 <= delta <= hi + 1e-12 for lo, hi in (interval(int(t[1]), int(t[2]), n) for t in tables)]
    return float(np.mean(hits))


def test_coverage_is_at_least_nominal_and_near_it_when_many_runs_differ():
    # The coverage estimate of N_TABLES studies has sd sqrt(0.95 * 0.05 / N_TABLES) = 0.0049 at the
    # nominal level: a design fails if its coverage is more than 3.5 sd below 95 %. Near nominal:
    # at n = 300 with at least 10 expected discordant runs the exact test's conservatism is small,
    # and coverage must stay under 95 % + 3.5 %.
    sd = np.sqrt(CONFIDENCE * (1 - CONFIDENCE) / N_TABLES)
    low_cov, high_cov = [], []
    for i, (pa, pb, rho, n) in enumerate(DESIGNS):
        cov = coverage(pa, pb, rho, n, seed=1000 + i)
        if cov < CONFIDENCE - 3.5 * sd:
            low_cov.append((pa, pb, rho, n, cov))
        p = cells(pa, pb, rho)
        if n == 300 and n * (p[1] + p[2]) >= 10 and cov > CONFIDENCE + 0.035:
            high_cov.append((pa, pb, rho, n, cov))
    assert len(DESIGNS) == 45  # 7 rate pairs x 3 correlations x 3 sizes, less the impossible tables
    assert not low_cov, f"coverage below nominal: {low_cov}"
    assert not high_cov, f"far above nominal with many discordant runs: {high_cov}"


def test_the_conditional_interval_alone_would_undercover():
    # (m / n)(tau_L, tau_U), the hand-made interval the psi term replaces: with the discordant runs
    # nearly all one way its upper limit is the estimate itself, and coverage falls far below 95 %
    pa, pb, rho, n = 0.8, 0.5, 0.5, 300
    tables = np.random.default_rng(7).multinomial(n, cells(pa, pb, rho), size=N_TABLES)

    def conditional(b, c):
        ci = stats.binomtest(b, b + c).proportion_ci(method="exact")
        return (b + c) / n * (2 * ci.low - 1), (b + c) / n * (2 * ci.high - 1)

    hits = [lo - 1e-12 <= pa - pb <= hi + 1e-12 for lo, hi in (conditional(int(t[1]), int(t[2])) for t in tables)]
    assert np.mean(hits) < 0.8
    assert coverage(pa, pb, rho, n, seed=7) >= CONFIDENCE - 3.5 * np.sqrt(CONFIDENCE * (1 - CONFIDENCE) / N_TABLES)


def test_a_limit_just_above_zero_is_not_printed_as_plus_zero():
    # 6 of 100 runs differ, all for A: p = 1/32 rejects, so the lower limit is above 0 (by under a point)
    r = ev.paired_rates(*paired_outcomes(50, 6, 0, 44))
    assert r.pvalue < 0.05 and 0 < r.difference_low < 0.01
    assert "interval +0." in str(r) and "interval +0 " not in str(r)


@pytest.mark.parametrize("confidence", [0.90, 0.99])
def test_consistency_holds_at_other_levels(confidence):
    for b in range(21):
        for c in range(21 - b):
            low, high = ev.paired_difference_interval(b, c, 60, confidence)
            p = 1.0 if b + c == 0 else stats.binomtest(b, b + c, 0.5).pvalue
            assert (low <= 0.0 <= high) == (p >= 1 - confidence), (b, c, p, low, high)
