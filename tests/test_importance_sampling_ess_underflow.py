"""Exercise 3.1's checker at the underflow case (review smc_is2 item 6): a sampler whose estimate is right
(log-domain weights) but whose ESS comes from un-shifted exp(log_w) gets its own sentence, which names the
ESS, not the estimate, and prints the estimate rounded."""

from __future__ import annotations

import numpy as np
from scipy import stats
from scipy.special import logsumexp

from pfcourse.book.exercises import IS_TOY_CASE, check_importance_sampler


def ess_from_unshifted_exp(z, sd_v, n, rng):
    x = z / 2 + rng.standard_normal(n)
    log_w = stats.norm.logpdf(z, loc=x, scale=sd_v) + stats.norm.logpdf(x) - stats.norm.logpdf(x, z / 2, 1.0)
    W = np.exp(log_w - logsumexp(log_w))
    w = np.exp(log_w)
    return W @ x, np.sum(w) ** 2 / np.sum(w**2)


def test_a_right_estimate_with_an_underflowing_ess_is_told_the_ess_is_wrong():
    estimate, ess = ess_from_unshifted_exp(*IS_TOY_CASE, 1000, np.random.default_rng(0))
    assert np.isfinite(estimate) and np.isfinite(ess)  # fine at the first case
    report = check_importance_sampler(ess_from_unshifted_exp)
    assert not report.ok and len(report.problems) == 1, str(report)
    problem = report.problems[0]
    assert "is right but the ESS is nan" in problem and "1 / sum(W**2)" in problem, problem
    estimate_text = problem.split("the estimate ")[1].split(" ")[0]
    assert len(estimate_text.split(".")[1]) == 4, problem  # rounded, not the raw float
