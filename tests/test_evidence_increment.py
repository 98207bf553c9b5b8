"""Exercise 3.2's checker: the log evidence increment log p(z_k | z_1:k-1) from weighted particles."""

import numpy as np
import pytest
from scipy.special import logsumexp

from pfcourse.book.exercises import check_evidence_increment, evidence_increment_case


def good(log_W, log_lik):
    return logsumexp(log_W + log_lik)


def linear(log_W, log_lik):
    return np.log(np.sum(np.exp(log_W) * np.exp(log_lik)))


def old_weights_dropped(log_W, log_lik):
    return logsumexp(log_lik) - np.log(len(log_lik))


def increment_not_log(log_W, log_lik):
    return np.exp(logsumexp(log_W + log_lik))


def max_not_added_back(log_W, log_lik):
    a = log_W + log_lik
    return np.log(np.sum(np.exp(a - a.max())))


def log_n_subtracted(log_W, log_lik):
    return logsumexp(log_W + log_lik) - np.log(len(log_W))


def test_the_case_is_exact_up_to_monte_carlo_error():
    """The weighted particles represent N(0, 1): their increment is within a few standard errors of
    the exact Gaussian value N(z; 0, 1 + sd_v^2) (self-normalised IS, relative error ~ sqrt(E w^2 / n))."""
    log_W, log_lik, exact = evidence_increment_case(0)
    W, lik = np.exp(log_W), np.exp(log_lik)
    estimate = np.sum(W * lik)
    se = np.sqrt(np.sum(W**2 * (lik - estimate) ** 2))  # delta-method standard error of the ratio
    assert abs(estimate - np.exp(exact)) < 4 * se
    log_W2, log_lik2, exact2 = evidence_increment_case(0, shift=-1000.0)
    assert np.all(np.exp(log_lik2) == 0.0) and np.isclose(exact2, exact - 1000.0)


def test_reference_passes():
    assert check_evidence_increment(good).ok


def test_underflow_is_named():
    report = check_evidence_increment(linear)
    assert len(report.problems) == 1
    assert "e^-1000" in report.problems[0] and "underflow" in report.problems[0] and "logsumexp" in report.problems[0]


def test_each_typical_mistake_gets_its_own_sentence():
    messages = {}
    for mistake, key in ((old_weights_dropped, "old weights log_W were dropped"),
                         (increment_not_log, "not its log"),
                         (max_not_added_back, "add it back"),
                         (log_n_subtracted, "log N was subtracted")):
        report = check_evidence_increment(mistake)
        assert not report.ok, mistake.__name__
        assert all(key in p for p in report.problems), (mistake.__name__, report.problems)
        messages[mistake.__name__] = report.problems[0].split(": ", 1)[1]
    assert len(set(messages.values())) == 4


def test_stubs_and_errors_get_a_plain_sentence():
    assert check_evidence_increment(lambda a, b: None).problems == [
        "the function returned None: return log p(z_k | z_1:k-1), one number"]
    assert "raised ZeroDivisionError" in str(check_evidence_increment(lambda a, b: 1 / 0))
    assert "one value per particle" in str(check_evidence_increment(lambda a, b: a + b))
    assert "is not logsumexp" in str(check_evidence_increment(lambda a, b: 0.0))


# The chapter's former exercise 3.2 checker, check_weight_update, still kept: its typical mistakes named.
def test_weight_update_names_four_typical_mistakes():
    from pfcourse.book.exercises import check_weight_update

    def weights_not_logs(log_W, log_lik):
        a = log_W + log_lik
        return np.exp(a - logsumexp(a))

    def underflow(log_W, log_lik):
        a = log_W + log_lik
        return a - np.log(np.sum(np.exp(a)))

    def old_dropped(log_W, log_lik):
        return log_lik - logsumexp(log_lik)

    def max_subtracted(log_W, log_lik):
        a = log_W + log_lik
        return a - np.max(a)

    keys = {weights_not_logs: "not their logs", underflow: "underflowed", old_dropped: "old weights log_W were dropped",
            max_subtracted: "subtract the logsumexp instead"}
    for mistake, key in keys.items():
        problems = check_weight_update(mistake).problems
        assert problems and any(key in p for p in problems), (mistake.__name__, problems)
        others = [k for k in keys.values() if k != key]
        assert not any(k in p for p in problems for k in others), (mistake.__name__, problems)


def test_importance_sampler_names_log_q_added():
    """Exercise 3.1: `+ log q` instead of `- log q` targets q^2 p(z | x) p(x), of mean 15/7 at (3, 0.5)."""
    from scipy import stats

    from pfcourse.book.exercises import IS_TOY_CASE, check_importance_sampler, toy_is_limit

    z, sd_v = IS_TOY_CASE
    assert toy_is_limit(z, sd_v, "proposal_added")[0] == pytest.approx(15 / 7)

    def plus_log_q(z, sd_v, n, rng):
        x = z / 2 + rng.standard_normal(n)
        log_w = stats.norm.logpdf(z, x, sd_v) + stats.norm.logpdf(x) + stats.norm.logpdf(x, z / 2, 1.0)
        W = np.exp(log_w - logsumexp(log_w))
        return W @ x, 1.0 / np.sum(W**2)

    problems = check_importance_sampler(plus_log_q).problems
    assert len(problems) == 1 and "adds log q(x) instead of subtracting it" in problems[0], problems
