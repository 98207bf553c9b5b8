"""The likelihood of a noise scale: exactness of the Kalman curve, unbiasedness of the
particle estimate, common random numbers, the ML search, and PMMH's target."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from pfcourse.errors import ParameterError
from pfcourse.scenarios.landmarks import quadrant_scenario, simulate
from pfcourse.likelihood import (
    grid_posterior,
    kalman_log_likelihood,
    max_likelihood_scale,
    pf_log_likelihood,
    scaled_model,
)
from pfcourse.pmmh import integrated_autocorrelation_time, pmmh


@pytest.fixture(scope="module")
def short():
    scenario = quadrant_scenario().with_(Qw=0.05**2 * np.eye(6), Rv=0.5**2 * np.eye(4), n_samples=15)
    return scenario, simulate(scenario, 7)


def joint_log_likelihood(scenario, Z, theta):
    """log N(z_obs; mean, cov) of all observed entries at once, from the model's linear map."""
    model = scaled_model(scenario, theta)
    K, d = Z.shape[0], model.dim_x
    F, H = model.F, model.H
    # x_k = F^k x_0 + sum_{j=1..k} F^{k-j} (B + w_j): stack the map from (x_0, w_1..w_{K-1}).
    means, maps = [], []
    mean, A = model.m0.copy(), np.hstack([np.eye(d), np.zeros((d, d * (K - 1)))])
    for k in range(K):
        if k > 0:
            mean = F @ mean + model.B
            A = F @ A
            A[:, d * k:d * (k + 1)] += np.eye(d)
        means.append(H @ mean)
        maps.append(H @ A)
    prior_cov = np.zeros((d * K, d * K))
    prior_cov[:d, :d] = model.P0
    for k in range(1, K):
        prior_cov[d * k:d * (k + 1), d * k:d * (k + 1)] = model.Q
    M, mu = np.vstack(maps), np.concatenate(means)
    cov = M @ prior_cov @ M.T + np.kron(np.eye(K), model.R)
    obs = ~np.isnan(Z.ravel())
    return stats.multivariate_normal(mu[obs], cov[np.ix_(obs, obs)]).logpdf(Z.ravel()[obs])


@pytest.mark.parametrize("theta", [0.3, 1.0, 4.0])
def test_kalman_curve_is_the_joint_gaussian_density(short, theta):
    scenario, sim = short
    assert kalman_log_likelihood(scenario, sim.measurements, theta) == pytest.approx(
        joint_log_likelihood(scenario, sim.measurements, theta), abs=1e-8)


def test_particle_likelihood_is_unbiased_and_its_log_biased_down(short):
    scenario, sim = short
    exact = kalman_log_likelihood(scenario, sim.measurements, 1.5)
    log_ratio = np.array([pf_log_likelihood(scenario, sim.measurements, 1.5, 100, seed) for seed in range(300)]) - exact
    ratio = np.exp(log_ratio)
    # E[Z^] = Z: the 99.9 % t-interval of the mean ratio contains 1.
    lo, hi = stats.t.interval(0.999, len(ratio) - 1, loc=ratio.mean(), scale=stats.sem(ratio))
    assert lo < 1 < hi
    # Jensen: E[log Z^] < log Z, and the 99.9 % interval of the mean log-ratio lies below 0.
    lo, hi = stats.t.interval(0.999, len(log_ratio) - 1, loc=log_ratio.mean(), scale=stats.sem(log_ratio))
    assert hi < 0


def test_common_random_numbers_make_the_curve_continuous(short):
    scenario, sim = short
    a = pf_log_likelihood(scenario, sim.measurements, 1.0, 200, 11)
    b = pf_log_likelihood(scenario, sim.measurements, 1.0 + 1e-7, 200, 11)
    other = [pf_log_likelihood(scenario, sim.measurements, 1.0, 200, s) for s in range(12, 32)]
    assert abs(a - b) < 1e-4  # same seed: the derivative is O(10) nats, so a 1e-7 step moves ~1e-6
    assert np.std(other) > 100 * abs(a - b)  # fresh seeds move it by the Monte Carlo sd


def test_max_likelihood_scale_is_a_stationary_point_of_the_exact_curve(short):
    scenario, sim = short
    f = lambda t: kalman_log_likelihood(scenario, sim.measurements, t)  # noqa: E731
    theta_hat, nfev = max_likelihood_scale(f, xatol=1e-6)
    h = 1e-4
    slope = (f(theta_hat * np.exp(h)) - f(theta_hat * np.exp(-h))) / (2 * h)
    assert abs(slope) < 1e-2
    assert all(f(theta_hat) >= f(t) for t in np.geomspace(0.1, 10, 41))
    assert nfev > 3


def test_grid_posterior_matches_the_lognormal():
    a, s = 0.2, 0.3
    u = np.linspace(a - 10 * s, a + 10 * s, 4001)
    density, mean, sd = grid_posterior(-0.5 * ((u - a) / s) ** 2, u)
    exact = stats.lognorm(s, scale=np.exp(a))
    assert mean == pytest.approx(exact.mean(), rel=1e-6)
    assert sd == pytest.approx(exact.std(), rel=1e-5)
    assert density.max() == pytest.approx(stats.norm(a, s).pdf(a), rel=1e-6)


def test_pmmh_with_a_noisy_unbiased_likelihood_targets_the_exact_posterior():
    """Pseudo-marginal property: log-noise N(-sigma^2/2, sigma^2) keeps E[Z^] = Z exact."""
    a, s, sigma = 0.0, 0.25, 1.0
    prior = stats.uniform(np.log(0.1), np.log(10) - np.log(0.1))

    def noisy(theta, rng):
        return -0.5 * ((np.log(theta) - a) / s) ** 2 + sigma * rng.standard_normal() - sigma**2 / 2

    chain = pmmh(noisy, prior, 1.0, 20000, 0.5, rng=3)
    u = np.log(chain.theta[1000:])
    tau = integrated_autocorrelation_time(u)
    mcse = u.std() * np.sqrt(tau / u.size)
    assert abs(u.mean() - a) < 4 * mcse
    assert u.std() == pytest.approx(s, rel=0.15)
    assert 0.05 < chain.acceptance_rate < 0.9


def test_integrated_autocorrelation_time_of_an_ar1():
    rng = np.random.default_rng(0)
    phi, n = 0.8, 200_000
    x = np.empty(n)
    x[0] = 0
    e = rng.standard_normal(n)
    for t in range(1, n):
        x[t] = phi * x[t - 1] + e[t]
    assert integrated_autocorrelation_time(x) == pytest.approx((1 + phi) / (1 - phi), rel=0.1)


def test_bad_input_raises_named_errors(short):
    scenario, sim = short
    with pytest.raises(ParameterError, match="theta"):
        kalman_log_likelihood(scenario, sim.measurements, -1.0)
    with pytest.raises(ParameterError, match="noise"):
        scaled_model(scenario, 1.0, "Pv")
    with pytest.raises(ParameterError, match="bounds"):
        max_likelihood_scale(lambda t: 0.0, bounds=(2.0, 1.0))
    with pytest.raises(ParameterError, match="prior"):
        pmmh(lambda t, r: 0.0, stats.uniform(0, 1), 100.0, 10, 0.1, 0)
