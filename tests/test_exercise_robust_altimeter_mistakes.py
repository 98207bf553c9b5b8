"""Exercise 17.4 (terrain): the four typical mistakes a navigation reviewer listed each get their own sentence.

Each mistake is written here as a student would write it, independently of the checker's own code:
the map read with row 0 north (the DEM file's order), the larger of the two mixture terms instead of
their sum, the mixture without its probabilities, and the product of the two terms. The reference
answer, written the same way, still passes.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from pfcourse.book.exercises.part2 import ROBUST_ALTIMETER_MISTAKES, check_robust_altimeter
from test_exercise_robust_altimeter import bilinear_by_hand

FOUR = ("north_up", "max_of_terms", "no_probabilities", "product_of_terms")


def _student(mistake=None):
    """A student's answer to exercise 17.4, with ``mistake`` (one of FOUR) or none."""

    def answer(particles, y, heights, dx, dy, rf, eps, y_max):
        if mistake == "north_up":
            heights = np.flipud(heights)
        inside, h = bilinear_by_hand(particles, heights, dx, dy)
        gauss = stats.norm.pdf(y, particles[:, 2] - h, np.sqrt(rf))
        if mistake == "max_of_terms":
            like = np.maximum((1 - eps) * gauss, eps / y_max)
        elif mistake == "no_probabilities":
            like = gauss + 1.0 / y_max
        elif mistake == "product_of_terms":
            like = (1 - eps) * gauss * eps / y_max
        else:
            like = (1 - eps) * gauss + eps / y_max
        with np.errstate(divide="ignore"):
            return np.where(inside, np.log(like), -np.inf)

    return answer


def test_the_reference_written_by_hand_passes():
    report = check_robust_altimeter(_student())
    assert report.ok, str(report)


@pytest.mark.parametrize("mistake", FOUR)
def test_each_of_the_four_mistakes_gets_its_own_sentence(mistake):
    report = check_robust_altimeter(_student(mistake))
    assert report.problems == [f"your function computes a known mistake: {ROBUST_ALTIMETER_MISTAKES[mistake]}"]


def test_the_four_sentences_are_distinct_and_name_what_is_wrong():
    sentences = [ROBUST_ALTIMETER_MISTAKES[m] for m in FOUR]
    assert len(set(sentences)) == len(FOUR)
    assert len(set(ROBUST_ALTIMETER_MISTAKES.values())) == len(ROBUST_ALTIMETER_MISTAKES)
    for mistake, word in zip(FOUR, ("row 0", "np.maximum", "1 - eps", "multiplies")):
        assert word in ROBUST_ALTIMETER_MISTAKES[mistake], mistake


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_mistakes_are_told_apart_on_other_test_draws(seed):
    """The checker's particles come from its seed: each mistake is named on other draws too."""
    assert check_robust_altimeter(_student(), seed=seed).ok
    for mistake in FOUR:
        report = check_robust_altimeter(_student(mistake), seed=seed)
        assert report.problems == [f"your function computes a known mistake: {ROBUST_ALTIMETER_MISTAKES[mistake]}"]
