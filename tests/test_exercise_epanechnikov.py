"""Exercise 18.2 (terrain_cure): the regularised filter's move with the Epanechnikov kernel.

The checker passes the reference answer (and one that draws the radius by rejection, another route to the
same law), names each typical mistake in its own sentence, and checks that the move draws from the
generator it is given.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import special, stats

from pfcourse.book.exercises.part2 import (EPANECHNIKOV_MISTAKES, check_epanechnikov_move, epanechnikov_bandwidth,
                                           epanechnikov_move)


def reference(particles, scale, rng):
    n, d = particles.shape
    c_d = np.pi ** (d / 2) / special.gamma(d / 2 + 1)
    A = (8 / c_d * (d + 4) * (2 * np.sqrt(np.pi)) ** d) ** (1 / (d + 4))
    h = scale * A * n ** (-1 / (d + 4))
    g = rng.standard_normal((n, d))
    r = np.sqrt(rng.beta(d / 2, 2, n))
    eps = g / np.linalg.norm(g, axis=1, keepdims=True) * r[:, None]
    # an eigen square root, not Cholesky: the kernel is round, so any root is right
    w, V = np.linalg.eigh(np.cov(particles, rowvar=False))
    return particles + h * eps @ (V * np.sqrt(w)).T


def by_rejection(particles, scale, rng):
    """Uniform points of the cube kept inside the ball, kept again with probability 1 - |eps|^2."""
    n, d = particles.shape
    h = scale * epanechnikov_bandwidth(n, d)
    eps = np.empty((0, d))
    while len(eps) < n:
        u = rng.uniform(-1, 1, (4 * n, d))
        r2 = np.sum(u**2, axis=1)
        keep = (r2 < 1) & (rng.random(4 * n) < 1 - r2)
        eps = np.vstack([eps, u[keep]])
    A = np.linalg.cholesky(np.cov(particles, rowvar=False))
    return particles + h * eps[:n] @ A.T


def test_the_bandwidth_is_musso_oudjane_le_gland_s():
    # d = 1: c_1 = 2, A = (8 / 2 * 5 * 2 sqrt(pi))^(1/5) = (40 sqrt(pi))^(1/5)
    assert epanechnikov_bandwidth(1, 1) == pytest.approx((40 * np.sqrt(np.pi)) ** 0.2, rel=1e-12)
    # d = 2: c_2 = pi, A = (8 / pi * 6 * 4 pi)^(1/6) = 192^(1/6)
    assert epanechnikov_bandwidth(1000, 2) == pytest.approx(192 ** (1 / 6) * 1000 ** (-1 / 6), rel=1e-12)


def test_the_kernel_has_the_epanechnikov_law():
    """Moves of the reference, whitened: |eps|^2 ~ Beta(d/2, 2) and covariance I / (d + 4)."""
    rng = np.random.default_rng(3)
    x = rng.standard_normal((50_000, 3)) * [3.0, 1.0, 0.1]
    moved = epanechnikov_move(x, 1.0, np.random.default_rng(4))
    L = np.linalg.cholesky(np.cov(x, rowvar=False))
    white = np.linalg.solve(L, (moved - x).T).T / epanechnikov_bandwidth(len(x), 3)
    assert np.sum(white**2, axis=1).max() <= 1.0
    assert stats.kstest(np.sum(white**2, axis=1), stats.beta(1.5, 2).cdf).pvalue > 1e-3
    assert np.allclose(np.cov(white, rowvar=False), np.eye(3) / 7, atol=6 * np.sqrt(2 / 50_000) / 7)


@pytest.mark.parametrize("answer", [reference, by_rejection, lambda p, s, rng: epanechnikov_move(p, s, rng)])
def test_correct_answers_pass(answer):
    report = check_epanechnikov_move(answer)
    assert report.ok, str(report)


def test_every_mistake_has_its_own_sentence():
    assert len(set(EPANECHNIKOV_MISTAKES.values())) == len(EPANECHNIKOV_MISTAKES) >= 4


@pytest.mark.parametrize("mistake", list(EPANECHNIKOV_MISTAKES))
def test_each_typical_mistake_is_named(mistake):
    report = check_epanechnikov_move(lambda p, s, rng: epanechnikov_move(p, s, rng, mistake))
    assert not report.ok
    assert report.problems == [f"your function computes a known mistake: {EPANECHNIKOV_MISTAKES[mistake]}"]


def test_the_printed_gaussian_move_is_not_the_answer():
    """The chapter's Gaussian move, bandwidth and all, does not pass."""
    def gaussian(p, scale, rng):
        n, d = p.shape
        h = scale * (4.0 / (d + 2)) ** (1.0 / (d + 4)) * n ** (-1.0 / (d + 4))
        return p + h * rng.standard_normal((n, d)) @ np.linalg.cholesky(np.cov(p, rowvar=False)).T

    report = check_epanechnikov_move(gaussian)
    assert not report.ok and "h long" in report.problems[0]


def test_the_generator_is_checked():
    def global_state(p, s, rng):
        return reference(p, s, np.random.default_rng(np.random.randint(1 << 30)))

    def own_seed(p, s, rng):
        return reference(p, s, np.random.default_rng(5))

    before = np.random.get_state()
    assert "global" in check_epanechnikov_move(global_state).problems[0]
    assert np.array_equal(np.random.get_state()[1], before[1])
    assert "seed" in check_epanechnikov_move(own_seed).problems[0]
    check_epanechnikov_move(reference)
    assert np.array_equal(np.random.get_state()[1], before[1])


def test_structural_mistakes_are_reported():
    shared = check_epanechnikov_move(lambda p, s, rng: p + rng.standard_normal(p.shape[1]))
    assert "same amount" in shared.problems[0]
    assert "returned None" in check_epanechnikov_move(lambda p, s, rng: None).problems[0]
    assert "shape" in check_epanechnikov_move(lambda p, s, rng: p[:10]).problems[0]
    off_centre = check_epanechnikov_move(lambda p, s, rng: reference(p, s, rng) + 0.05 * np.sqrt(np.diag(
        np.cov(p, rowvar=False))))
    assert "average to zero" in off_centre.problems[0]


def test_a_wrong_bandwidth_is_blamed_on_the_bandwidth():
    """c_d taken as the unit sphere's area (d times the ball's volume): the right kernel, the wrong h."""
    def sphere_area(p, scale, rng):
        n, d = p.shape
        return p + (d ** (-1.0 / (d + 4))) * (reference(p, scale, rng) - p)

    report = check_epanechnikov_move(sphere_area)
    assert not report.ok
    assert "bandwidth" in report.problems[0] and "Beta" not in report.problems[0]
    stretch = float(report.problems[0].split("shape but ")[1].split(" times")[0])
    assert stretch == pytest.approx(3 ** (-1 / 7), abs=0.02)
