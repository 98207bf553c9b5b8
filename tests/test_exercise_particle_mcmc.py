"""The particle MCMC chapter's exercise checker: the reference passes, each typical mistake is named."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats
from scipy.special import logsumexp

from pfcourse.book.exercises.particle_mcmc import ANCESTOR_MISTAKES, check_ancestor_index


def reference(log_W, x_prev, x_ref, a, sigma, rng):
    log_p = log_W + stats.norm.logpdf(x_ref, a * x_prev, sigma)
    return int(rng.choice(len(x_prev), p=np.exp(log_p - logsumexp(log_p))))


def drawing(log_terms, linear=False):
    def fn(log_W, x_prev, x_ref, a, sigma, rng):
        t = log_terms(log_W, x_prev, x_ref, a, sigma)
        p = np.exp(t) / np.exp(t).sum() if linear else np.exp(t - logsumexp(t))
        return int(rng.choice(len(x_prev), p=p))
    return fn


MISTAKES = {
    "weights": drawing(lambda W, x, r, a, s: W),
    "transition": drawing(lambda W, x, r, a, s: stats.norm.logpdf(r, a * x, s)),
    "reversed": drawing(lambda W, x, r, a, s: W + stats.norm.logpdf(x, a * r, s)),
    "variance": drawing(lambda W, x, r, a, s: W + stats.norm.logpdf(r, a * x, s**2)),
}


def test_the_reference_passes():
    report = check_ancestor_index(reference)
    assert report.ok, str(report)


@pytest.mark.parametrize("mistake", list(MISTAKES))
def test_each_typical_mistake_is_named(mistake):
    report = check_ancestor_index(MISTAKES[mistake])
    assert not report.ok and ANCESTOR_MISTAKES[mistake] in report.problems[0]


def test_the_linear_domain_underflows():
    report = check_ancestor_index(drawing(lambda W, x, r, a, s: W + stats.norm.logpdf(r, a * x, s), linear=True))
    assert not report.ok and "-1000" in report.problems[0]


def test_the_generator_is_checked():
    def global_state(log_W, x_prev, x_ref, a, sigma, rng):
        return reference(log_W, x_prev, x_ref, a, sigma, np.random.default_rng(np.random.randint(1 << 30)))

    def own_seed(log_W, x_prev, x_ref, a, sigma, rng):
        return reference(log_W, x_prev, x_ref, a, sigma, np.random.default_rng(2))  # draws 2, not the most probable 3

    def most_probable(log_W, x_prev, x_ref, a, sigma, rng):
        return int(np.argmax(log_W + stats.norm.logpdf(x_ref, a * x_prev, sigma)))

    before = np.random.get_state()
    assert "global" in check_ancestor_index(global_state).problems[0]
    assert np.array_equal(np.random.get_state()[1], before[1])
    assert "same index every time" in check_ancestor_index(most_probable).problems[0]
    assert "another seed" in check_ancestor_index(own_seed).problems[0]


def test_a_wrong_return_is_reported():
    assert "not an integer index" in check_ancestor_index(lambda *a: 0.5).problems[0]
    assert "returned None" in check_ancestor_index(lambda *a: None).problems[0]
