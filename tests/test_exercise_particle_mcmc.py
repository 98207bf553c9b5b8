"""The particle MCMC chapter's exercise checker (ancestor sampling with correlated process noise):
the reference passes, each typical mistake is named in its own sentence, underflow and the generator
are checked."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import logsumexp

from pfcourse.book.exercises.particle_mcmc import ANCESTOR_CASE, ANCESTOR_MISTAKES, check_ancestor_index


def quadratic(d, M):
    return np.einsum("ni,ij,nj->n", d, M, d)


def drawing(log_terms, linear=False):
    """A student's function: draw j with probability proportional to exp(log_terms(...))."""
    def fn(log_W, x_prev, x_ref, F, Q, rng):
        t = log_terms(log_W, x_prev, x_ref, F, Q)
        p = np.exp(t) / np.exp(t).sum() if linear else np.exp(t - logsumexp(t))
        return int(rng.choice(len(x_prev), p=p))
    return fn


def exact_terms(W, x, r, F, Q):
    return W - 0.5 * quadratic(r - x @ F.T, np.linalg.inv(Q))


reference = drawing(exact_terms)

MISTAKES = {
    "weights": drawing(lambda W, x, r, F, Q: W),
    "transition": drawing(lambda W, x, r, F, Q: -0.5 * quadratic(r - x @ F.T, np.linalg.inv(Q))),
    "diagonal": drawing(lambda W, x, r, F, Q: W - 0.5 * np.sum((r - x @ F.T) ** 2 / np.diag(Q), axis=1)),
    "covariance": drawing(lambda W, x, r, F, Q: W - 0.5 * quadratic(r - x @ F.T, Q)),
    "reversed": drawing(lambda W, x, r, F, Q: W - 0.5 * quadratic(x - r @ F.T, np.linalg.inv(Q))),
    "no_dynamics": drawing(lambda W, x, r, F, Q: W - 0.5 * quadratic(r - x, np.linalg.inv(Q))),
    "transposed": drawing(lambda W, x, r, F, Q: W - 0.5 * quadratic(r - x @ F, np.linalg.inv(Q))),
}


def test_the_reference_passes():
    report = check_ancestor_index(reference)
    assert report.ok, str(report)


def test_a_reference_with_scipy_passes():
    from scipy import stats

    def with_scipy(log_W, x_prev, x_ref, F, Q, rng):
        log_p = log_W + stats.multivariate_normal(cov=Q).logpdf(x_ref - x_prev @ F.T)
        return int(rng.choice(len(x_prev), p=np.exp(log_p - logsumexp(log_p))))

    assert check_ancestor_index(with_scipy).ok


def test_every_mistake_has_its_own_sentence():
    assert set(MISTAKES) == set(ANCESTOR_MISTAKES)
    assert len(set(ANCESTOR_MISTAKES.values())) == len(ANCESTOR_MISTAKES) >= 4


@pytest.mark.parametrize("mistake", list(MISTAKES))
def test_each_typical_mistake_is_named(mistake):
    report = check_ancestor_index(MISTAKES[mistake])
    assert not report.ok and ANCESTOR_MISTAKES[mistake] in report.problems[0], str(report)


def test_the_mistakes_are_far_from_the_exact_probabilities():
    """Each mistake moves the probabilities enough that 3000 draws reject it (noncentrality >= 100)."""
    from pfcourse.book.exercises.particle_mcmc import N_DRAWS, ancestor_probabilities
    exact = ancestor_probabilities(**ANCESTOR_CASE)
    for mistake in ANCESTOR_MISTAKES:
        p = ancestor_probabilities(**ANCESTOR_CASE, mistake=mistake)
        assert N_DRAWS * np.sum((p - exact) ** 2 / exact) > 100, mistake


def test_the_linear_domain_underflows():
    report = check_ancestor_index(drawing(exact_terms, linear=True))
    assert not report.ok and "-1000" in report.problems[0]


def test_the_generator_is_checked():
    def global_state(log_W, x_prev, x_ref, F, Q, rng):
        return reference(log_W, x_prev, x_ref, F, Q, np.random.default_rng(np.random.randint(1 << 30)))

    def own_seed(log_W, x_prev, x_ref, F, Q, rng):
        return reference(log_W, x_prev, x_ref, F, Q, np.random.default_rng(0))  # draws 2, not the most probable 1

    def most_probable(log_W, x_prev, x_ref, F, Q, rng):
        return int(np.argmax(exact_terms(log_W, x_prev, x_ref, F, Q)))

    before = np.random.get_state()
    assert "global" in check_ancestor_index(global_state).problems[0]
    assert np.array_equal(np.random.get_state()[1], before[1])
    assert "same index every time" in check_ancestor_index(most_probable).problems[0]
    assert "another seed" in check_ancestor_index(own_seed).problems[0]
    # the reference leaves NumPy's global state untouched and gives one answer per seed
    check_ancestor_index(reference)
    assert np.array_equal(np.random.get_state()[1], before[1])


def test_a_wrong_return_is_reported():
    assert "not an integer index" in check_ancestor_index(lambda *a: 0.5).problems[0]
    assert "returned None" in check_ancestor_index(lambda *a: None).problems[0]
