"""PMMH over two noise scales (pfcourse.pmmh) and the exact 2-D grid posterior (pfcourse.likelihood)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from pfcourse import ParameterError
from pfcourse.likelihood import grid_posterior_2d, kalman_log_likelihood, scaled_model
from pfcourse.pmmh import pmmh
from pfcourse.scenarios.landmarks import quadrant_scenario


def test_two_scales_scale_both_covariances():
    sc = quadrant_scenario()
    m = scaled_model(sc, (2.0, 3.0), ("Qw", "Rv"))
    np.testing.assert_allclose(m.Q, 2.0 * sc.model().Q)
    np.testing.assert_allclose(m.R, 3.0 * sc.model().R)
    for theta, noise in [((1.0,), ("Qw", "Rv")), ((1.0, 1.0), ("Qw", "Qw")), ((1.0, -1.0), ("Qw", "Rv"))]:
        with pytest.raises(ParameterError):
            scaled_model(sc, theta, noise)


def test_grid_posterior_2d_of_a_gaussian_log_likelihood():
    # l(u) = -(u1 - a)^2 / (2 s1^2) - (u2 - b)^2 / (2 s2^2): theta_j = exp(u_j) is log-normal, so its
    # posterior mean is exp(a + s1^2 / 2) and sd exp(a + s1^2 / 2) sqrt(exp(s1^2) - 1)
    a, s1, b, s2 = 0.2, 0.3, -0.4, 0.1
    u1, u2 = np.linspace(a - 8 * s1, a + 8 * s1, 801), np.linspace(b - 8 * s2, b + 8 * s2, 601)
    ll = -(u1[:, None] - a) ** 2 / (2 * s1**2) - (u2[None, :] - b) ** 2 / (2 * s2**2)
    g = grid_posterior_2d(ll, u1, u2)
    for (m, s), key in (((a, s1), "theta1"), ((b, s2), "theta2")):
        mean = np.exp(m + s**2 / 2)
        assert g[f"{key}_mean"] == pytest.approx(mean, rel=1e-5)
        assert g[f"{key}_sd"] == pytest.approx(mean * np.sqrt(np.expm1(s**2)), rel=1e-4)


def test_vector_pmmh_with_the_exact_likelihood_targets_the_grid_posterior():
    # with the exact (Kalman) likelihood PMMH is plain random-walk Metropolis on (log q, log r):
    # its posterior mean of theta_r lies within a few Monte Carlo standard errors of the grid's
    sc = quadrant_scenario().with_(Qw=0.05**2 * np.eye(6), Rv=0.5**2 * np.eye(4))
    from pfcourse.scenarios.landmarks import simulate
    Z = simulate(sc, 7).measurements[:20]
    prior = stats.uniform(np.log(0.1), np.log(10.0) - np.log(0.1))
    chain = pmmh(lambda t, rng: kalman_log_likelihood(sc, Z, t, ("Qw", "Rv")), prior, np.array([1.0, 1.0]),
                 3000, 0.4, 0)
    assert chain.theta.shape == (3000, 2)
    u = np.linspace(np.log(0.1), np.log(10.0), 41)
    ll = np.array([[kalman_log_likelihood(sc, Z, (np.exp(a), np.exp(b)), ("Qw", "Rv")) for b in u] for a in u])
    g = grid_posterior_2d(ll, u, u)
    r = chain.theta[500:, 1]
    # Monte Carlo standard error with batch means (30 batches)
    batches = r[: len(r) // 30 * 30].reshape(30, -1).mean(axis=1)
    se = batches.std(ddof=1) / np.sqrt(30)
    assert abs(r.mean() - g["theta2_mean"]) < 4 * se + 0.02 * g["theta2_sd"]
    assert 0.1 < chain.acceptance_rate < 0.9
