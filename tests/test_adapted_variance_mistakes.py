"""Exercise 25.1's checker tells the bootstrap's variance r^2 apart from q^2 + r (student_p5, item 1): at the
checker's q = 1, r = 1.5 the two are 2.25 and 2.5 and their runs match each other's, so a probe at r = 0.5
(0.25 against 1.5) decides which one the answer computes; each gets its own sentence."""

import numpy as np
import pytest
from scipy.special import logsumexp

from pfcourse.book.exercises import check_adapted_likelihood
from pfcourse.book.exercises.part5 import ADAPTED_MISTAKES, ADAPTED_PROBE_R, ADAPTED_Q, ADAPTED_R


def student(z, n, rng, a, q, r, variance):
    """The fully adapted filter as a student writes it (multinomial resampling via rng.choice), with the
    predictive variance given by ``variance(q, r)``."""
    x = rng.standard_normal(n)
    s2 = 1.0 / (1 / q**2 + 1 / r**2)
    ll = 0.0
    for zk in z:
        v = variance(q, r)
        lw = -0.5 * np.log(2 * np.pi * v) - 0.5 * (zk - a * x) ** 2 / v
        ll += logsumexp(lw) - np.log(n)
        x = x[rng.choice(n, n, p=np.exp(lw - logsumexp(lw)))]
        x = s2 * (a * x / q**2 + zk / r**2) + np.sqrt(s2) * rng.standard_normal(n)
    return ll


def test_the_two_variances_are_close_at_the_checker_s_values_and_far_at_the_probe_s():
    assert abs(ADAPTED_R**2 - (ADAPTED_Q**2 + ADAPTED_R)) < 0.3
    assert (ADAPTED_Q**2 + ADAPTED_PROBE_R) / ADAPTED_PROBE_R**2 > 5


@pytest.mark.parametrize("variance, mistake", [
    (lambda q, r: r**2, "r_only"),
    (lambda q, r: q**2 + r, "r_not_squared"),
])
def test_each_variance_slip_gets_its_own_sentence(variance, mistake):
    report = check_adapted_likelihood(lambda z, n, rng, a, q, r: student(z, n, rng, a, q, r, variance))
    assert not report.ok and report.problems == [ADAPTED_MISTAKES[mistake]], str(report)


def test_the_correct_variance_passes():
    report = check_adapted_likelihood(lambda z, n, rng, a, q, r: student(z, n, rng, a, q, r,
                                                                         lambda q, r: q**2 + r**2))
    assert report.ok, str(report)


def test_the_fixed_lag_checker_names_tracing_every_step_from_the_end():
    """Exercise 27.2 (student_p5, item 17): the chapter's own loop traces from the last step T; the checker
    says each step has its own end."""
    from pfcourse.book.exercises import check_fixed_lag

    def from_end(particles, weights, ancestors, lag):
        T = len(weights) - 1
        means = []
        for k in range(T + 1):
            idx = np.arange(weights.shape[1])
            for j in range(T, k, -1):
                idx = ancestors[j][idx]
            means.append(weights[T] @ particles[k][idx])
        return np.array(means)

    report = check_fixed_lag(from_end)
    assert not report.ok and "own end t = min(k + L, T)" in report.problems[0], str(report)


def test_the_storvik_checker_names_numpy_s_gamma_scale_slip():
    """Exercise 28.1 (student_p5, item 12): 1 / rng.gamma(a, b) reads NumPy's scale as a rate."""
    from scipy import stats

    from pfcourse.book.exercises.static_parameters import STORVIK_R, check_storvik_step

    def slip(x, a, b, z, rng):
        theta = 1 / rng.gamma(a, b)
        x_new = x + np.sqrt(theta) * rng.standard_normal(x.shape)
        log_w = stats.norm.logpdf(z, x_new, np.sqrt(STORVIK_R))
        return x_new, a + 0.5, b + (x_new - x) ** 2 / 2, log_w

    report = check_storvik_step(slip)
    assert not report.ok and "SCALE" in report.problems[0], str(report)
