"""Parts I and III capstone checkers name a cause only when the evidence shows it (review smc_p3, items 6 and
13): the count filter's dropped -exp(mu + x) term, found by counts of 0, the symptom alone for a spread the
probe does not explain; the SV filter's dropped log(2 pi) / 2, its move of standard deviation sigma^2 (found by
returns of 0) and its likelihood variance beta e^x (found with beta = 2, which the capstone's beta = 1 hides)."""

import numpy as np
import pytest
from scipy.special import logsumexp

from pfcourse.book.exercises import check_count_filter, check_sv_filter


def count_filter(y, n, rng, model, mistake=None):
    x = model.sigma / np.sqrt(1 - model.phi ** 2) * rng.standard_normal(n)
    means = np.empty(len(y))
    for k, yk in enumerate(y):
        x = model.phi * x + model.sigma * rng.standard_normal(n)
        log_g = yk * (model.mu + x) - (0.0 if mistake == "no_exp" else np.exp(model.mu + x))
        w = np.exp(log_g - logsumexp(log_g))
        means[k] = w @ x
        x = x[rng.choice(n, size=n, p=w)]
    return means


def sv_filter(y, n, rng, model, mistake=None):
    x = model.sigma / np.sqrt(1 - model.phi ** 2) * rng.standard_normal(n)
    means, log_lik = np.empty(len(y)), 0.0
    sd = model.sigma ** 2 if mistake == "sigma_variance" else model.sigma
    var_beta = model.beta if mistake == "beta_variance" else model.beta ** 2
    for k, yk in enumerate(y):
        x = model.phi * x + sd * rng.standard_normal(n)
        var = var_beta * np.exp(x)
        log_w = -0.5 * ((0.0 if mistake == "no_2pi" else np.log(2 * np.pi)) + np.log(var) + yk ** 2 / var)
        log_c = logsumexp(log_w)
        log_lik += log_c - np.log(n)
        w = np.exp(log_w - log_c)
        means[k] = w @ x
        x = x[rng.choice(n, size=n, p=w)]
    return means, log_lik


def test_a_dropped_exp_term_in_the_count_weights_is_named():
    """Resampled, but log g = y (mu + x): its means vary over seeds about 21 times a resampled filter's; told of
    five counts of 0 its means stay at the predicted cloud's 0 (within 0.1) where the exact filter's fall to -1.92."""
    report = check_count_filter(lambda y, n, rng, m: count_filter(y, n, rng, m, "no_exp"), n_runs=6)
    assert not report.ok and len(report.problems) == 1, str(report)
    assert "-exp(mu + x_k) term" in report.problems[0] and "without resampling" not in report.problems[0]


def test_a_large_spread_without_a_shown_cause_names_the_symptom():
    """SIS (no resampling): the zero-count probe does not fire (its weights still use -exp(mu + x)), so the
    sentence gives both causes of collapsed weights rather than one."""
    from test_capstone_part3 import report_of
    problem = report_of("sis", 6).problems[0]
    assert "collapse onto a few particles" in problem and "far too peaked" in problem, problem


@pytest.mark.parametrize("mistake, says, n_runs", [
    ("no_2pi", "T log(2 pi) / 2 too large", 8),
    ("sigma_variance", "move of standard deviation sigma^2", 8),
    ("beta_variance", "variance beta e^x", 8),
])
def test_each_sv_filter_mistake_gets_its_own_sentence(mistake, says, n_runs):
    """Measured (8 runs): ``no_2pi`` the likelihood gap is T * 0.919 = 55.1 nats; ``sigma_variance`` not near its
    own large-N limit on the capstone's returns (its small moves converge slowly), but on three returns of 0 its
    last mean is -1.35 against the mistake's -1.32 and the exact -1.78; ``beta_variance`` passes the capstone's
    model (beta = 1) and is found with beta = 2: last mean near the mistake's 0.62, the exact 0.16."""
    report = check_sv_filter(lambda y, n, rng, m: sv_filter(y, n, rng, m, mistake), n_runs=n_runs)
    assert not report.ok and len(report.problems) == 1, str(report)
    assert says in report.problems[0], report.problems[0]


def test_the_sv_reference_passes_the_probes():
    assert check_sv_filter(sv_filter, n_runs=8).ok
