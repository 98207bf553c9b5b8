"""Tests of the evidence helpers added for the review of Parts III and V (fix35)."""
import numpy as np
import pytest
from scipy import stats

from pfcourse import evidence
from pfcourse.errors import PfcourseError


def test_log_mean_exp_gaussian_is_mean_plus_half_variance():
    x = np.random.default_rng(0).normal(-1.0, 1.2, 200_000)
    # the exact log E[e^X] of N(-1, 1.44) is -1 + 0.72; the third cumulant is 0
    assert evidence.log_mean_exp(x, order=2) == pytest.approx(-0.28, abs=0.02)
    assert evidence.log_mean_exp(x, order=3) == pytest.approx(-0.28, abs=0.03)


def test_log_mean_exp_third_cumulant_corrects_a_skewed_sample():
    # X = -G with G ~ Gamma(k=4, scale=0.5): log E[e^X] = -k log(1 + scale) exactly
    x = -np.random.default_rng(1).gamma(4.0, 0.5, 400_000)
    exact = -4.0 * np.log(1.5)
    second, third = evidence.log_mean_exp(x, 2), evidence.log_mean_exp(x, 3)
    # cumulants of -G: -k scale = -2, k scale^2 = 1, -2 k scale^3 = -1: Gaussian value -1.5, third order -1.6667
    assert second == pytest.approx(-1.5, abs=0.01)
    assert third == pytest.approx(-1.5 - 1 / 6, abs=0.015)
    assert abs(third - exact) < abs(second - exact)


def test_log_mean_exp_rejects_bad_input():
    with pytest.raises(PfcourseError):
        evidence.log_mean_exp([1.0, 2.0, 3.0])
    with pytest.raises(PfcourseError):
        evidence.log_mean_exp(np.arange(10.0), order=4)


def test_iact_relative_sd_matches_sokal_and_a_simulation():
    assert evidence.iact_relative_sd(10.0, 1300) == pytest.approx(np.sqrt(2 * 101 / 1300))
    # AR(1) with rho = 0.8: tau = (1 + rho) / (1 - rho) = 9; spread of the estimate over chains
    from pfcourse.pmmh import integrated_autocorrelation_time
    rng = np.random.default_rng(2)
    n, rho, taus = 1300, 0.8, []
    for _ in range(200):
        e = rng.standard_normal(n + 200)
        x = np.empty_like(e)
        x[0] = e[0]
        for t in range(1, e.size):
            x[t] = rho * x[t - 1] + np.sqrt(1 - rho**2) * e[t]
        taus.append(integrated_autocorrelation_time(x[200:]))
    predicted = evidence.iact_relative_sd(9.0, n)
    measured = np.std(taus, ddof=1) / 9.0
    # Sokal's formula is an asymptotic approximation: agree within a factor of 1.6
    assert predicted / 1.6 < measured < predicted * 1.6


def test_iact_relative_sd_rejects_bad_input():
    with pytest.raises(PfcourseError):
        evidence.iact_relative_sd(0.5, 100)
    with pytest.raises(PfcourseError):
        evidence.iact_relative_sd(2.0, 1)
