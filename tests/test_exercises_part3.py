"""check_adaptive_residual (exercise 19.1): the reference passes, each typical mistake gets its own sentence,
the generator is checked, NumPy's global state is left alone."""

import numpy as np
import pytest

from pfcourse.book.exercises import ADAPTIVE_MISTAKES, adaptive_residual, check_adaptive_residual


def test_the_reference_passes_on_several_seeds():
    for seed in (0, 1, 2):
        assert check_adaptive_residual(adaptive_residual, seed=seed).ok


def test_the_reference_keeps_floor_copies_and_is_unbiased():
    log_w = np.log(np.array([0.39, 0.31, 0.2, 0.1]))
    counts = np.array([np.bincount(adaptive_residual(np.arange(4.0), log_w, 1.0, np.random.default_rng(s))[0]
                                   .astype(int), minlength=4) for s in range(4000)])
    assert (counts >= np.floor(4 * np.exp(log_w))).all()
    assert np.allclose(counts.mean(axis=0), 4 * np.exp(log_w), atol=0.05)


@pytest.mark.parametrize("mistake", list(ADAPTIVE_MISTAKES))
def test_each_typical_mistake_gets_its_own_sentence(mistake):
    report = check_adaptive_residual(lambda p, lw, tau, rng: adaptive_residual(p, lw, tau, rng, mistake))
    assert not report.ok and report.problems == [ADAPTIVE_MISTAKES[mistake]], str(report)


@pytest.mark.parametrize("feed, says", [
    (lambda rng: np.random, "NumPy's global generator"),
    (lambda rng: np.random.default_rng(), "same seed gave different"),
    (lambda rng: np.random.default_rng(7), "whatever the generator's seed"),
])
def test_the_generator_is_checked(feed, says):
    report = check_adaptive_residual(lambda p, lw, tau, rng: adaptive_residual(p, lw, tau, feed(rng)))
    assert not report.ok and says in report.problems[0], str(report)


def test_other_answers_are_explained():
    assert "returned None" in check_adaptive_residual(lambda p, lw, tau, rng: None).problems[0]
    assert "two arrays" in check_adaptive_residual(lambda p, lw, tau, rng: 3).problems[0]
    moved = check_adaptive_residual(lambda p, lw, tau, rng: (p + 0.5, lw))
    assert "copies of the particles" in moved.problems[0]
    short = check_adaptive_residual(lambda p, lw, tau, rng: (p[:-1], lw[:-1]))
    assert "return N = 10 particles" in short.problems[0]


def test_the_checker_leaves_numpys_global_state_alone():
    np.random.seed(5)
    expected = np.random.random()
    np.random.seed(5)
    check_adaptive_residual(lambda p, lw, tau, rng: adaptive_residual(p, lw, tau, np.random))
    assert np.random.random() == expected
