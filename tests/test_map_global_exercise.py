"""The map-global chapter's checker (pfcourse.book.exercises.map_global): the reference answer passes, each typical
mistake is named with its own message, the generator is checked, and a broken answer is reported, never raised."""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.book.exercises.map_global import (RESET_MISTAKES, Corridor, check_reset_weights, exact_evidence,
                                           reset_answer)


def test_the_reference_passes():
    report = check_reset_weights(reset_answer)
    assert report.ok, str(report)


@pytest.mark.parametrize("mistake", list(RESET_MISTAKES))
def test_each_mistake_is_named_with_its_own_message(mistake):
    report = check_reset_weights(lambda z, n, rng, c: reset_answer(z, n, rng, c, mistake))
    assert report.problems == [RESET_MISTAKES[mistake]]


def test_the_global_generator_is_named():
    def global_draws(z, n, rng, c):
        return reset_answer(z, n, np.random.default_rng(np.random.randint(1 << 30)), c)

    state = np.random.get_state()
    report = check_reset_weights(global_draws)
    assert len(report.problems) == 1 and "global np.random" in report.problems[0]
    assert np.array_equal(np.random.get_state()[1], state[1])  # the checker restored NumPy's global state


def test_a_fixed_seed_inside_is_named():
    report = check_reset_weights(lambda z, n, rng, c: reset_answer(z, n, np.random.default_rng(0), c))
    assert len(report.problems) == 1 and "another seed gave the same poses" in report.problems[0]


def test_a_broken_answer_is_reported_not_raised():
    def broken(z, n, rng, c):
        raise RuntimeError("not written yet")

    report = check_reset_weights(broken)
    assert report.problems == ["the function raised RuntimeError: not written yet"]


def test_a_partial_mixture_is_caught_by_the_evidence():
    """q from the picked candidate's kernel alone (not the mixture): the mean weight no longer estimates Z."""
    def picked_only(z, n, rng, c):
        cand = rng.uniform(0.0, c.L, c.m)
        s = c.log_likelihood(cand, z)
        v = np.exp(s - s.max())
        v /= v.sum()
        j = rng.choice(c.m, size=n, p=v)
        x = cand[j] + c.h * rng.standard_normal(n)
        log_q = np.log(v[j]) - 0.5 * ((x - cand[j]) / c.h) ** 2 - np.log(np.sqrt(2 * np.pi) * c.h)
        return x, c.log_prior(x) - log_q + c.log_likelihood(x, z)

    report = check_reset_weights(picked_only)
    assert len(report.problems) == 1 and "whole mixture" in report.problems[0]


def test_the_exact_evidence_is_a_converged_quadrature():
    c = Corridor()
    Z, mean = exact_evidence(1.1, c)
    Z2, mean2 = exact_evidence(1.1, c, n_grid=50001)
    assert abs(Z / Z2 - 1) < 1e-6 and abs(mean - mean2) < 1e-6
    # the evidence is the likelihood averaged over the corridor: at most the sensor's peak density over L... times L
    assert 0 < Z < 1 / (np.sqrt(2 * np.pi) * c.sigma)


def test_an_unanswered_exercise_says_what_to_return():
    report = check_reset_weights(lambda z, n, rng, c: None)
    assert report.problems == ["the function returned None: return the poses and their log-weights, two arrays of "
                               "shape (n,)"]


def test_the_student_reviews_wrong_answer_fails():
    """rng.choice without p= while q stays the likelihood-weighted mixture: biased, and named (issue 41 review)."""
    def no_p(z, n, rng, c):
        cand = rng.uniform(0.0, c.L, c.m)
        s = c.log_likelihood(cand, z)
        log_v = s - np.logaddexp.reduce(s)
        x = cand[rng.choice(c.m, size=n)] + c.h * rng.standard_normal(n)
        log_k = -0.5 * ((x[:, None] - cand) / c.h) ** 2 - np.log(np.sqrt(2 * np.pi) * c.h)
        log_q = np.logaddexp.reduce(log_v + log_k, axis=1)
        return x, c.log_prior(x) - log_q + c.log_likelihood(x, z)

    report = check_reset_weights(no_p)
    assert report.problems == [RESET_MISTAKES["uniform_pick"]]


def test_rng_normal_for_the_noise_is_accepted():
    def with_normal(z, n, rng, c):
        cand = rng.uniform(0.0, c.L, c.m)
        s = c.log_likelihood(cand, z)
        log_v = s - np.logaddexp.reduce(s)
        x = rng.normal(cand[rng.choice(c.m, size=n, p=np.exp(log_v))], c.h)
        log_k = -0.5 * ((x[:, None] - cand) / c.h) ** 2 - np.log(np.sqrt(2 * np.pi) * c.h)
        return x, c.log_prior(x) - np.logaddexp.reduce(log_v + log_k, axis=1) + c.log_likelihood(x, z)

    assert check_reset_weights(with_normal).ok
