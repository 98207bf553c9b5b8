"""Exercise 17.4 (terrain): the log-likelihood of an altimeter whose reading is junk with probability eps.

The checker passes the reference answer, names each typical mistake in its own sentence, and the
reference itself is the mixture density, checked against a direct computation and scipy.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats
from scipy.ndimage import map_coordinates

from pfcourse.book.exercises.part2 import (ALTIMETER_DX, ALTIMETER_DY, ALTIMETER_HEIGHTS, ALTIMETER_RF,
                                           ROBUST_ALTIMETER_MISTAKES, ROBUST_EPS, ROBUST_Y_MAX,
                                           check_robust_altimeter, robust_altimeter_log_likelihood)


def reference(particles, y, heights, dx, dy, rf, eps, y_max):
    """The answer written apart from the checker's and the chapter's code: the height by scipy's bilinear
    interpolation (``map_coordinates`` of order 1, rows indexed by y / dy and columns by x / dx), the Gaussian
    term by scipy's normal log-density."""
    ny, nx = heights.shape
    col, row = particles[:, 0] / dx, particles[:, 1] / dy
    inside = (col >= 0) & (col <= nx - 1) & (row >= 0) & (row <= ny - 1)
    h = map_coordinates(heights, [row, col], order=1, mode="nearest")
    log_gauss = stats.norm.logpdf(y, particles[:, 2] - h, np.sqrt(rf))
    return np.where(inside, np.logaddexp(np.log1p(-eps) + log_gauss, np.log(eps / y_max)), -np.inf)


@pytest.mark.parametrize("seed", range(3))
def test_the_reference_passes(seed):
    report = check_robust_altimeter(reference, seed=seed)
    assert report.ok, str(report)


def test_the_mixture_is_a_density_in_y():
    """For a particle on the map, the likelihood integrates to one over readings in [0, y_max] (plus the
    Gaussian's tiny mass outside it)."""
    p = np.array([[300.0, 250.0, 1000.0, 0.0]])
    ys = np.linspace(-2000.0, ROBUST_Y_MAX + 2000.0, 200_001)
    like = np.array([np.exp(robust_altimeter_log_likelihood(p, y, ALTIMETER_HEIGHTS, ALTIMETER_DX, ALTIMETER_DY,
                                                            ALTIMETER_RF, ROBUST_EPS, ROBUST_Y_MAX))[0]
                     for y in ys[::100]])
    # the junk term is written for every y here (the checker keeps y inside [0, y_max]); subtract what it adds
    # outside the range, then the integral is one
    dy = ys[100] - ys[0]
    outside = (ys[::100] < 0) | (ys[::100] > ROBUST_Y_MAX)
    integral = np.sum(like) * dy - np.sum(outside) * dy * ROBUST_EPS / ROBUST_Y_MAX
    assert integral == pytest.approx(1.0, abs=2e-3)


def test_every_mistake_has_its_own_sentence():
    assert len(set(ROBUST_ALTIMETER_MISTAKES.values())) == len(ROBUST_ALTIMETER_MISTAKES) >= 4


@pytest.mark.parametrize("mistake", list(ROBUST_ALTIMETER_MISTAKES))
def test_each_typical_mistake_is_named(mistake):
    def wrong(particles, y, heights, dx, dy, rf, eps, y_max):
        return robust_altimeter_log_likelihood(particles, y, heights, dx, dy, rf, eps, y_max, mistake=mistake)

    report = check_robust_altimeter(wrong)
    assert report.problems == [f"your function computes a known mistake: {ROBUST_ALTIMETER_MISTAKES[mistake]}"]


def test_the_mistakes_differ_from_the_answer_and_from_each_other():
    rng = np.random.default_rng(0)
    p = np.column_stack([rng.uniform(0, 600, 50), rng.uniform(0, 550, 50), rng.normal(1000, 80, 50),
                         np.zeros(50)])
    args = (600.0, ALTIMETER_HEIGHTS, ALTIMETER_DX, ALTIMETER_DY, ALTIMETER_RF, ROBUST_EPS, ROBUST_Y_MAX)
    values = {m: robust_altimeter_log_likelihood(p, *args, mistake=m) for m in [None, *ROBUST_ALTIMETER_MISTAKES]}
    keys = list(values)
    for a in range(len(keys)):
        for b in range(a + 1, len(keys)):
            assert not np.allclose(values[keys[a]], values[keys[b]]), (keys[a], keys[b])


def test_other_wrong_answers_are_reported():
    def finite_off_map(particles, *args):
        out = reference(particles, *args)
        return np.where(np.isfinite(out), out, 0.0)

    assert "off the map" in check_robust_altimeter(finite_off_map).problems[0]
    assert "particle" in check_robust_altimeter(lambda p, *a: reference(p, *a) + 0.5 * (p[:, 0] > 300)).problems[0]
    assert "returned None" in check_robust_altimeter(lambda *a: None).problems[0]
    assert "shape" in check_robust_altimeter(lambda p, *a: reference(p, *a)[:5]).problems[0]


def bilinear_by_hand(particles, heights, dx, dy, corners_swapped=False):
    """A student's bilinear reading of the map (row 0 south): ``(inside, h)`` for every particle."""
    ny, nx = heights.shape
    col, row = particles[:, 0] / dx, particles[:, 1] / dy
    inside = (col >= 0) & (col <= nx - 1) & (row >= 0) & (row <= ny - 1)
    j = np.clip(np.floor(col), 0, nx - 2).astype(int)
    i = np.clip(np.floor(row), 0, ny - 2).astype(int)
    s, t = col - j, row - i
    h10, h01 = (heights[i + 1, j], heights[i, j + 1]) if corners_swapped else (heights[i, j + 1], heights[i + 1, j])
    return inside, (1 - s) * (1 - t) * heights[i, j] + s * (1 - t) * h10 + (1 - s) * t * h01 + s * t * heights[i + 1, j + 1]


def _by_hand(corners_swapped=False, dx_for_dy=False):
    """A student's answer written out, with one of the two mistakes the text warns about."""
    def answer(particles, y, heights, dx, dy, rf, eps, y_max):
        inside, h = bilinear_by_hand(particles, heights, dx, dx if dx_for_dy else dy, corners_swapped)
        log_gauss = -0.5 * (y - (particles[:, 2] - h)) ** 2 / rf - 0.5 * np.log(2 * np.pi * rf)
        return np.where(inside, np.logaddexp(np.log1p(-eps) + log_gauss, np.log(eps / y_max)), -np.inf)
    return answer


@pytest.mark.parametrize("mistake", ["corners_swapped", "dx_for_dy"])
def test_the_non_square_cell_mistakes_written_by_hand_are_named(mistake):
    """The two mistakes a map with non-square cells invites, written independently of the checker's code."""
    assert ALTIMETER_DX != ALTIMETER_DY
    assert _by_hand()(np.array([[10.0, 10.0, 1000.0, 0.0]]), 600.0, ALTIMETER_HEIGHTS, ALTIMETER_DX, ALTIMETER_DY,
                      ALTIMETER_RF, ROBUST_EPS, ROBUST_Y_MAX).shape == (1,)
    assert check_robust_altimeter(_by_hand()).ok
    report = check_robust_altimeter(_by_hand(**{mistake: True}))
    assert report.problems == [f"your function computes a known mistake: {ROBUST_ALTIMETER_MISTAKES[mistake]}"]
