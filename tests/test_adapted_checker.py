"""The fully adapted likelihood checker (exercise 25.1) after the SMC review (issue 39): its data make a
filter that never resamples biased, and each mistake is named only when its runs match the answer's in
mean and in spread. A student's code (systematic resampling, written apart from the reference) is checked
with the reference's answer and with each typical mistake; each gets its own sentence."""

import numpy as np
import pytest
from scipy.special import logsumexp

from pfcourse.book.exercises import adapted_log_likelihood, check_adapted_likelihood
from pfcourse.book.exercises.part5 import (ADAPTED_A, ADAPTED_Q, ADAPTED_R, adapted_data,
                                           scalar_kalman_log_likelihood)


def student(z, n, rng, a, q, r, mistake=None):
    """The fully adapted filter as a student writes it (systematic resampling), one mistake switched on."""
    x = rng.standard_normal(n)
    s2 = 1 / (1 / q**2 + 1 / r**2)
    total = 0.0
    for zk in z:
        var = q**2 + (r if mistake == "r_not_squared" else r**2)
        log_w = -0.5 * (np.log(2 * np.pi * var) + (zk - a * x) ** 2 / var)
        total += logsumexp(log_w) - np.log(n)
        if mistake != "no_resampling":
            w = np.exp(log_w - logsumexp(log_w))
            u = (np.arange(n) + rng.random()) / n
            x = x[np.minimum(np.searchsorted(np.cumsum(w), u), n - 1)]
        sd = s2 if mistake == "sd_as_var" else np.sqrt(s2)
        if mistake == "move_without_z":
            x = a * x + np.sqrt(s2) * rng.standard_normal(n)
        else:
            x = s2 * (a * x / q**2 + zk / r**2) + sd * rng.standard_normal(n)
    return total


def test_the_data_make_the_reading_less_informative_than_the_move():
    assert ADAPTED_R > ADAPTED_Q and ADAPTED_R != ADAPTED_R**2


def test_the_student_reference_passes_at_two_seeds():
    for seed in (0, 7):
        report = check_adapted_likelihood(student, seed=seed)
        assert report.ok, str(report)


@pytest.mark.parametrize("mistake, says", [
    ("no_resampling", "never resamples"),
    ("r_not_squared", "variance q^2 + r: r is a standard deviation"),
    ("sd_as_var", "standard deviation s^2"),
])
def test_the_review_s_mistakes_are_caught_and_named(mistake, says):
    report = check_adapted_likelihood(lambda *args: student(*args, mistake=mistake))
    assert not report.ok and len(report.problems) == 1, str(report)
    assert says in report.problems[0], report.problems[0]


def test_a_mistake_without_its_own_sentence_is_not_given_another_s():
    """Moving from the transition's mean with the posterior's spread is biased like the prior move in mean,
    not in spread: the checker says how far the answer is instead of naming a mistake it did not make."""
    report = check_adapted_likelihood(lambda *args: student(*args, mistake="move_without_z"))
    assert not report.ok and len(report.problems) == 1, str(report)
    assert "nats off" in report.problems[0], report.problems[0]


def test_a_filter_that_drops_the_weights_is_biased_on_the_checker_s_data():
    """The property the data were chosen for: with r > q a filter that never resamples is off by more than
    the tolerance, measured on 200 runs apart from the checker's seeds."""
    z = adapted_data()
    args = (ADAPTED_A, ADAPTED_Q, ADAPTED_R)
    exact = scalar_kalman_log_likelihood(z, *args)
    runs = np.array([adapted_log_likelihood(z, 100, np.random.default_rng(90_000 + s), *args, "no_resampling")
                     for s in range(200)])
    gap = runs.mean() + runs.var(ddof=1) / 2 - exact
    se = runs.std(ddof=1) / np.sqrt(runs.size)
    assert abs(gap) - 3 * se > 4 * se + 0.05
