"""Exercise 3.1's checker sees weights computed outside the log domain (issue 39; reviews smc_is item 9,
student_is): at IS_UNDERFLOW_CASE (z = 60, sd_v = 1) p(z | x) p(x) is about e^-900 at every draw, below
the smallest positive float, so a sampler that multiplies densities, or exponentiates its log-weights
before subtracting their maximum, returns 0 / 0. Each such answer passes the first case and gets the
underflow sentence; the reference passes both, silently.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy import stats
from scipy.special import logsumexp

from pfcourse.book.exercises import IS_TOY_CASE, IS_UNDERFLOW_CASE, check_importance_sampler
from pfcourse.book.exercises.part1 import _gauss_chi2, toy_is_ess_ratio, toy_is_limit


def reference(z, sd_v, n, rng):
    x = z / 2 + rng.standard_normal(n)
    log_w = stats.norm.logpdf(z, loc=x, scale=sd_v) + stats.norm.logpdf(x) - stats.norm.logpdf(x, z / 2, 1.0)
    W = np.exp(log_w - logsumexp(log_w))
    return W @ x, 1.0 / np.sum(W**2)


def densities(z, sd_v, n, rng):
    """The weights as a product of densities, normalised by their sum."""
    x = z / 2 + rng.standard_normal(n)
    w = stats.norm.pdf(z, loc=x, scale=sd_v) * stats.norm.pdf(x) / stats.norm.pdf(x, z / 2, 1.0)
    W = w / w.sum()
    return W @ x, 1.0 / np.sum(W**2)


def exp_then_normalise(z, sd_v, n, rng):
    """Log-weights, exponentiated before the normalisation (nothing subtracted first)."""
    x = z / 2 + rng.standard_normal(n)
    log_w = stats.norm.logpdf(z, loc=x, scale=sd_v) + stats.norm.logpdf(x) - stats.norm.logpdf(x, z / 2, 1.0)
    W = np.exp(log_w) / np.sum(np.exp(log_w))
    return W @ x, 1.0 / np.sum(W**2)


def nan_to_zero(z, sd_v, n, rng):
    """The linear-domain weights with NaN replaced by 0 (a 'fix' that hides the underflow)."""
    estimate, ess = densities(z, sd_v, n, rng)
    return np.nan_to_num(estimate), np.nan_to_num(ess, nan=1.0)


def max_only_once(z, sd_v, n, rng):
    """Right at the first case; at the second, an estimate anchored on one draw (the largest weight)."""
    x = z / 2 + rng.standard_normal(n)
    log_w = stats.norm.logpdf(z, loc=x, scale=sd_v) + stats.norm.logpdf(x) - stats.norm.logpdf(x, z / 2, 1.0)
    if z > 10:
        return float(x[np.argmax(log_w)]), 1.0
    W = np.exp(log_w - logsumexp(log_w))
    return W @ x, 1.0 / np.sum(W**2)


def test_the_case_underflows_and_its_exact_answer_is_reachable():
    z, sd_v = IS_UNDERFLOW_CASE
    x = z / 2 + np.linspace(-6, 6, 1001)  # the proposal's draws, far into both tails
    product = stats.norm.pdf(z, loc=x, scale=sd_v) * stats.norm.pdf(x)
    assert np.all(product == 0.0)  # p(z | x) p(x) underflows everywhere a draw can land
    mean, var = toy_is_limit(z, sd_v)
    assert (mean, var) == pytest.approx((z / (1 + sd_v**2), sd_v**2 / (1 + sd_v**2)))
    # the proposal N(z/2, 1) sits on the posterior N(30, 1/2): E_q w^2 = 2 / sqrt(3), ESS / n tends to sqrt(3) / 2
    assert toy_is_ess_ratio(z, sd_v) == pytest.approx(np.sqrt(3) / 2, rel=1e-12)
    assert _gauss_chi2(mean, var, z / 2, 1.0)[1] == pytest.approx(2 / np.sqrt(3) / 3, rel=1e-12)


@pytest.mark.parametrize("seed", range(3))
def test_the_reference_passes_both_cases_without_a_warning(seed):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        report = check_importance_sampler(reference, seed=seed)
    assert report.ok, str(report)


@pytest.mark.parametrize("sampler", [densities, exp_then_normalise])
def test_weights_outside_the_log_domain_get_the_underflow_sentence(sampler):
    assert np.isfinite(sampler(*IS_TOY_CASE, 1000, np.random.default_rng(0))[0])  # fine at the first case
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the checker silences the 0 / 0 warnings: its sentence says it
        report = check_importance_sampler(sampler)
    assert not report.ok and len(report.problems) == 1, str(report)
    assert "underflow to 0" in report.problems[0] and "logsumexp" in report.problems[0], report.problems[0]


@pytest.mark.parametrize("sampler", [nan_to_zero, max_only_once])
def test_a_finite_wrong_answer_at_the_underflow_case_is_named(sampler):
    report = check_importance_sampler(sampler)
    assert not report.ok and len(report.problems) == 1, str(report)
    assert "is not the exact posterior mean 30.0000" in report.problems[0], report.problems[0]


def test_a_sampler_that_raises_at_the_underflow_case_is_named():
    def raises(z, sd_v, n, rng):
        if z > 10:
            raise FloatingPointError("underflow")
        return reference(z, sd_v, n, rng)

    report = check_importance_sampler(raises)
    assert not report.ok and "raised FloatingPointError" in report.problems[0], str(report)


def test_the_checker_leaves_numpys_global_state_alone():
    np.random.seed(11)
    expected = np.random.random()
    np.random.seed(11)
    check_importance_sampler(densities)
    assert np.random.random() == expected


def test_adding_log_q_instead_of_subtracting_it_is_named():
    """The sign slip of review smc_is item 9: its limit q^2 x lik x prior has mean 15/7 at z = 3, sd_v = 0.5."""
    def plus_log_q(z, sd_v, n, rng):
        x = z / 2 + rng.standard_normal(n)
        log_w = stats.norm.logpdf(z, loc=x, scale=sd_v) + stats.norm.logpdf(x) + stats.norm.logpdf(x, z / 2, 1.0)
        W = np.exp(log_w - logsumexp(log_w))
        return W @ x, 1.0 / np.sum(W**2)

    assert toy_is_limit(*IS_TOY_CASE, "proposal_added")[0] == pytest.approx(15 / 7)
    report = check_importance_sampler(plus_log_q)
    assert not report.ok and len(report.problems) == 1, str(report)
    assert "adds log q(x) instead of subtracting it" in report.problems[0], report.problems[0]
