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
