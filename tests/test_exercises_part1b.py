"""The stratified-resampler checker of Part I's resampling chapter (exercise 6.3; issue 39, item 6).

The reference passes; each typical mistake, the systematic scheme (one uniform shared by all) and the
multinomial one (uniforms anywhere) among them, is named in its own sentence, and a resampler that draws
from anything but the generator it is given is caught.
"""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.exercises.part1 import STRATIFIED_WEIGHTS, _offspring_variances, check_stratified_resampler


def invert(w, u, shift=0, cap=True):
    idx = np.searchsorted(np.cumsum(w), u, side="right") + shift
    return np.minimum(idx, len(w) - 1) if cap else idx


def stratified(w, rng):  # the chapter's solution
    n = len(w)
    return invert(w, (np.arange(n) + rng.random(n)) / n)


MISTAKES = {
    # one uniform for all strata: systematic resampling, unbiased, less variable than stratified here
    "systematic": (lambda w, rng: invert(w, (np.arange(len(w)) + rng.random()) / len(w)),
                   "the copies vary like systematic resampling's"),
    # independent uniforms anywhere in [0, 1): multinomial resampling
    "multinomial": (lambda w, rng: invert(w, np.sort(rng.random(len(w)))),
                    "the copies vary like multinomial resampling's"),
    # NumPy's global generator instead of the one given
    "global state": (lambda w, rng: invert(w, (np.arange(len(w)) + np.random.random(len(w))) / len(w)),
                     "it draws from NumPy's global generator"),
    # a fresh unseeded generator inside the function
    "own generator": (lambda w, rng: stratified(w, np.random.default_rng()),
                      "two calls with generators of the same seed gave different answers"),
    # the midpoint of each stratum: no randomness at all
    "midpoints": (lambda w, rng: invert(w, (np.arange(len(w)) + 0.5) / len(w)),
                  "the result never changes with the seed"),
    # the index one too far, not capped
    "off by one": (lambda w, rng: invert(w, (np.arange(len(w)) + rng.random(len(w))) / len(w), shift=1, cap=False),
                   "draw 0: an index is out of range"),
    # the index one too far, capped: the weightless particle after a heavy one gets its copies
    "shifted": (lambda w, rng: invert(w, (np.arange(len(w)) + rng.random(len(w))) / len(w), shift=1),
                "a particle of weight 0 was chosen"),
    # strata of width 1 / (N + 1): the last part of the bar is never reached
    "narrow strata": (lambda w, rng: invert(w, (np.arange(len(w)) + rng.random(len(w))) / (len(w) + 1)),
                      "biased: particle"),
    # float indices
    "float indices": (lambda w, rng: stratified(w, rng).astype(float), "returned dtype float64"),
}


def test_the_reference_passes_and_leaves_the_global_state_alone():
    np.random.seed(5)
    before = np.random.get_state()[1].copy()
    report = check_stratified_resampler(stratified)
    assert report.ok, str(report)
    assert np.array_equal(np.random.get_state()[1], before)


@pytest.mark.parametrize("mistake", MISTAKES, ids=str)
def test_each_typical_mistake_gets_its_own_sentence(mistake):
    fn, says = MISTAKES[mistake]
    report = check_stratified_resampler(fn)
    assert len(report.problems) == 1, str(report)
    assert report.problems[0].startswith(says), str(report)


def test_the_global_generator_mistake_leaves_the_global_state_as_it_found_it():
    np.random.seed(11)
    before = np.random.get_state()[1].copy()
    check_stratified_resampler(MISTAKES["global state"][0])
    assert np.array_equal(np.random.get_state()[1], before)


def test_the_messages_are_distinct():
    assert len({says for _, says in MISTAKES.values()}) == len(MISTAKES)


def test_the_weights_tell_the_schemes_apart():
    """Particle 1 sits astride two strata: systematic gives it one copy always, stratified 0, 1 or 2."""
    exact = _offspring_variances(STRATIFIED_WEIGHTS)
    assert STRATIFIED_WEIGHTS.sum() == pytest.approx(1.0)
    assert exact["systematic"][1] == pytest.approx(0.0)
    assert exact["stratified"][1] == pytest.approx(0.5)
    assert exact["multinomial"][1] == pytest.approx(7 / 8)


def test_the_exact_stratified_variances_are_those_measured():
    rng = np.random.default_rng(3)
    counts = np.array([np.bincount(stratified(STRATIFIED_WEIGHTS, rng), minlength=8) for _ in range(20_000)])
    measured = counts.var(axis=0, ddof=1)
    # a variance of a count in {0, 1, 2} has a standard error below sqrt(1 / 20000) = 0.007
    assert np.allclose(measured, _offspring_variances(STRATIFIED_WEIGHTS)["stratified"], atol=0.04)


def test_nothing_returned_and_counts_returned_are_named():
    assert check_stratified_resampler(lambda w, rng: None).problems == [
        "the function returned None: write the resampler and return the N ancestor indices"]
    report = check_stratified_resampler(lambda w, rng: np.zeros((len(w), 2), dtype=int))
    assert report.problems[0].startswith("returned shape (8, 2)")
