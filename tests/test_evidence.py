"""pfcourse.evidence: rates, paired tests and intervals, against closed forms and their coverage."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from pfcourse import evidence as ev


def wilson_closed_form(k: int, n: int, z: float = stats.norm.ppf(0.975)) -> tuple[float, float]:
    p = k / n
    centre = (p + z**2 / (2 * n)) / (1 + z**2 / n)
    half = z * np.sqrt(p * (1 - p) / n + z**2 / (4 * n**2)) / (1 + z**2 / n)
    return centre - half, centre + half


@pytest.mark.parametrize("k,n", [(0, 100), (2, 100), (67, 100), (100, 100), (3, 7)])
def test_rate_is_the_wilson_score_interval(k, n):
    r = ev.rate(k, n)
    low, high = wilson_closed_form(k, n)
    assert (r.low, r.high) == pytest.approx((max(low, 0.0), min(high, 1.0)), abs=1e-12)
    assert r.estimate == k / n
    assert ev.rate(np.arange(n) < k) == r  # from a boolean array of runs


def test_mcnemar_is_the_exact_binomial_test_on_discordant_runs():
    # 62 runs rescued by B and none lost: p = 2 * (1/2)^62 (two-sided exact)
    a = np.r_[np.ones(62, bool), np.zeros(38, bool)]
    b = np.zeros(100, bool)
    r = ev.paired_rates(a, b)
    assert (r.only_a, r.only_b) == (62, 0)
    assert r.pvalue == pytest.approx(2 * 0.5**62, rel=1e-9)
    assert r.difference == pytest.approx(0.62)
    assert r.difference_low < 0.62 < r.difference_high
    # concordant runs carry no information: adding 1000 runs where both succeed changes nothing
    more = ev.paired_rates(np.r_[a, np.ones(1000, bool)], np.r_[b, np.ones(1000, bool)])
    assert more.pvalue == r.pvalue
    assert ev.paired_rates(a, a).pvalue == 1.0


def test_paired_wilcoxon_holds_its_level_under_the_null():
    # a and b exchangeable: the test rejects at 5 % in about 5 % of 400 seeded studies
    rng = np.random.default_rng(1)
    rejections = 0
    for _ in range(400):
        x = rng.gamma(2.0, size=(2, 60))
        rejections += ev.paired(x[0], x[1]).pvalue < 0.05
    # 99.9 % binomial range for p = 0.05, n = 400
    low, high = stats.binom.ppf([0.0005, 0.9995], 400, 0.05)
    assert low <= rejections <= high


def test_median_difference_interval_covers_the_true_median():
    # d = a - b with median 0.3; the 95 % percentile-bootstrap interval should cover it in about
    # 95 % of studies (the percentile bootstrap of a median is first-order accurate: allow 90-99 %)
    rng = np.random.default_rng(2)
    covered = 0
    n_studies = 200
    for i in range(n_studies):
        b = rng.normal(size=100)
        a = b + 0.3 + rng.standard_t(5, size=100)
        p = ev.paired(a, b, seed=i)
        covered += p.low <= 0.3 <= p.high
    assert 0.90 * n_studies <= covered <= 0.99 * n_studies


def test_verdicts_and_detectable_difference():
    rng = np.random.default_rng(3)
    b = rng.normal(size=150)
    same = ev.paired(b + rng.normal(0, 0.2, 150), b)
    assert same.verdict() == "no difference detected"
    assert same.detectable == max(abs(same.low), abs(same.high))
    assert same.low < 0 < same.high
    worse = ev.paired(b + 0.5 + rng.normal(0, 0.2, 150), b)
    assert worse.verdict() == "A higher" and worse.low > 0
    better = ev.paired(b - 0.5 + rng.normal(0, 0.2, 150), b)
    assert better.verdict() == "A lower" and better.high < 0


def test_ratio_is_the_difference_of_logs():
    rng = np.random.default_rng(4)
    a, b = rng.lognormal(size=80), rng.lognormal(size=80)
    r, d = ev.paired(a, b, ratio=True), ev.paired(np.log(a), np.log(b))
    assert r.median == pytest.approx(np.exp(d.median))
    assert (r.low, r.high) == pytest.approx((np.exp(d.low), np.exp(d.high)))
    assert r.pvalue == d.pvalue
    assert r.detectable == pytest.approx(max(r.high, 1 / r.low))


def test_all_ties_give_p_one_and_a_zero_interval():
    x = np.linspace(1, 2, 30)
    p = ev.paired(x, x)
    assert (p.pvalue, p.median, p.low, p.high) == (1.0, 0.0, 0.0, 0.0)
    assert p.verdict() == "no difference detected"


def test_sign_test_counts_directions_and_drops_ties():
    a = np.array([1, 2, 3, 4, 5, 6.0])
    b = np.array([2, 3, 4, 4, 1, 7.0])
    below, above, p = ev.sign_test(a, b)
    assert (below, above) == (4, 1)
    assert p == pytest.approx(stats.binomtest(4, 5).pvalue)


def test_median_interval_brackets_the_median():
    x = np.random.default_rng(5).exponential(size=101)
    m, low, high = ev.median_interval(x)
    assert m == np.median(x) and low <= m <= high


@pytest.mark.parametrize("call,match", [
    (lambda: ev.paired([1, 2, 3], [1, 2]), "same number of runs"),
    (lambda: ev.paired([1, np.nan, 3], [1, 2, 3]), "non-finite value.*run 1"),
    (lambda: ev.paired([], []), "no runs"),
    (lambda: ev.paired([[1, 2]], [[1, 2]]), "1-D"),
    (lambda: ev.paired([1, 0], [1, 2], ratio=True), "positive"),
    (lambda: ev.rate(5, 3), "successes <= n"),
    (lambda: ev.rate(2.5, 10), "whole number"),
    (lambda: ev.rate(1, 10, confidence=1.5), "confidence"),
    (lambda: ev.paired_rates([0, 2, 1], [0, 1, 1]), "booleans"),
    (lambda: ev.paired_rates([True, False], [True]), "same number of runs"),
])
def test_bad_runs_get_a_named_error(call, match):
    with pytest.raises(ev.EvidenceError, match=match):
        call()


def test_run_interval_of_a_slope_covers_the_true_slope_and_pairs_its_arrays():
    """A log-log slope fitted over runs: its interval covers the true slope at about the nominal
    rate, and a difference of two slopes on the same runs is resampled together (paired)."""
    n_values = np.array([100, 300, 1000, 3000])
    x = np.log(n_values)
    covered = 0
    for rep in range(40):
        rng = np.random.default_rng(rep)
        u = rng.normal(0.0, 1.0, 50)  # a run's own slope perturbation, shared by both "filters"
        a = np.exp(-(0.5 + 0.2 * u) * x[:, None] + rng.normal(0.0, 0.05, (4, 50)))
        b = np.exp(-(0.3 + 0.2 * u) * x[:, None] + rng.normal(0.0, 0.05, (4, 50)))

        def slope(e, r):
            return float(np.polyfit(x, np.mean(np.log(e[:, r]), axis=1), 1)[0])

        value, low, high = ev.run_interval(lambda r: slope(a, r), 50, seed=rep, n_resamples=999)
        covered += low <= -0.5 <= high
        if rep == 0:
            d, dl, dh = ev.run_interval(lambda r: slope(a, r) - slope(b, r), 50, seed=rep, n_resamples=999)
            # paired: the shared noise cancels, so the difference is much tighter than either slope
            assert dl < -0.2 < dh and (dh - dl) < 0.5 * (high - low)
    assert covered >= 32  # 95 % nominal; 32 of 40 is the 1st percentile of Binomial(40, 0.95)


def test_run_interval_of_several_statistics_at_once():
    x = np.random.default_rng(0).normal(size=200)
    value, low, high = ev.run_interval(lambda r: np.array([np.mean(x[r]), np.median(x[r])]), 200, n_resamples=999)
    assert value.shape == low.shape == high.shape == (2,)
    single = ev.run_interval(lambda r: np.mean(x[r]), 200, n_resamples=999)
    assert value[0] == single[0] and np.all(low < value) and np.all(value < high)


def test_a_vectorized_statistic_gives_the_same_interval():
    """The same resamples, one call: the interval of a statistic that takes a 2-D array of indices is
    that of the one-resample-at-a-time statistic, float for float."""
    x = np.random.default_rng(1).lognormal(size=150)
    one = ev.run_interval(lambda r: np.mean(x[r]) / np.median(x[r]), 150, seed=4, n_resamples=999)
    rows = ev.run_interval(lambda r: np.mean(x[r], axis=-1) / np.median(x[r], axis=-1), 150, seed=4,
                           n_resamples=999, vectorized=True)
    assert one == rows


def test_log_slope_is_the_least_squares_slope_of_the_resampled_centres():
    """log_slope (vectorized) against the slope written for one resample at a time: the same floats."""
    sizes = np.array([30, 100, 300, 1000, 3000])
    rng = np.random.default_rng(2)
    a, b = rng.lognormal(size=(2, 5, 60)) * sizes[:, None] ** -0.5
    x = np.log(sizes)

    def slope(e, r, center=np.median):
        y = np.log(center(e[:, r], axis=1))
        return float(np.sum((x - x.mean()) * (y - y.mean())) / np.sum((x - x.mean()) ** 2))

    assert ev.log_slope(a, sizes, seed=3) == ev.run_interval(lambda r: slope(a, r), 60, seed=3)
    assert ev.log_slope(a, sizes, against=b, seed=3) == ev.run_interval(lambda r: slope(a, r) - slope(b, r), 60,
                                                                        seed=3)
    assert ev.log_slope(a, sizes, center=np.mean) == ev.run_interval(lambda r: slope(a, r, np.mean), 60)


@pytest.mark.parametrize("n_runs", [1, 0, 2.5])
def test_run_interval_refuses_too_few_runs(n_runs):
    with pytest.raises(ev.EvidenceError, match="at least 2 runs"):
        ev.run_interval(lambda r: 0.0, n_runs)


def test_log_slope_recovers_a_power_law_and_the_difference_of_two():
    sizes = np.array([30, 100, 300, 1000])
    rng = np.random.default_rng(5)
    scale = rng.lognormal(0.0, 0.3, size=40)           # each run its own constant: e_jr = c_r N_j^b
    sir, rbpf = scale * sizes[:, None] ** -0.25, scale * sizes[:, None] ** -0.5
    b, low, high = ev.log_slope(rbpf, sizes)
    assert b == pytest.approx(-0.5) and low == pytest.approx(-0.5) and high == pytest.approx(-0.5)
    d, low, high = ev.log_slope(rbpf, sizes, against=sir)
    assert d == pytest.approx(-0.25) and low == pytest.approx(-0.25) and high == pytest.approx(-0.25)
    noisy = rbpf * rng.lognormal(0.0, 0.5, size=rbpf.shape)
    b, low, high = ev.log_slope(noisy, sizes, center=np.mean)
    assert low < -0.5 < high and low < b < high
    with pytest.raises(ev.EvidenceError, match="shape"):
        ev.log_slope(noisy[:, :3], sizes[:2])


def test_regression_slope_is_the_least_squares_slope_with_a_t_interval_of_its_level():
    """Points y = 1 - 0.7 x + N(0, 0.2^2) at five x: the t interval (3 degrees of freedom) covers the
    true slope in 95 % of 2000 data sets, within 4 binomial standard deviations (sd 0.49 %)."""
    x = np.log([100, 300, 1000, 3000, 10000])
    rng = np.random.default_rng(11)
    y = 1.0 - 0.7 * x + rng.normal(0.0, 0.2, size=(2000, x.size))
    fits = [ev.regression_slope(x, row) for row in y]
    assert fits[0][0] == np.polyfit(x, y[0], 1)[0]  # the point fit itself, bit for bit
    covered = np.mean([low <= -0.7 <= high for _, low, high in fits])
    assert abs(covered - 0.95) < 4 * np.sqrt(0.95 * 0.05 / 2000)
    exact = ev.regression_slope(x, 2.0 + 0.5 * x)
    assert exact[0] == pytest.approx(0.5) and exact[2] - exact[1] == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(ev.EvidenceError, match="at least 3 points"):
        ev.regression_slope(x[:2], y[0, :2])
