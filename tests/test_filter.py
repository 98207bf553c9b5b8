"""The particle filter: convergence to the exact Kalman posterior, determinism, error paths."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from pfcourse import (
    DegenerateWeightsError,
    DensityProposal,
    LinearGaussianModel,
    NumericalError,
    OptimalProposal,
    ParameterError,
    ParticleFilter,
    ShapeError,
    StateSpaceModel,
    kalman_filter,
)
from pfcourse.collectors import Clouds
from pfcourse.gaussian import gaussian_logpdf
from pfcourse.scenarios.landmarks.scenario import quadrant_scenario, simulate

N_VALUES = (250, 1000, 4000)
N_RUNS = 40


@pytest.fixture(scope="module")
def convergence_runs(noisy_landmarks):
    """Mean-squared error against the Kalman mean and log-likelihood error, per N and run."""
    model, sim, kf = noisy_landmarks
    mse = np.empty((len(N_VALUES), N_RUNS))
    loglik_error = np.empty((len(N_VALUES), N_RUNS))
    for a, n in enumerate(N_VALUES):
        pf = ParticleFilter(model, n, threshold=0.5)
        for seed in range(N_RUNS):
            result = pf.run(sim.measurements, rng=seed)
            mse[a, seed] = np.mean((result.mean - kf.mean) ** 2)
            loglik_error[a, seed] = result.log_likelihood - kf.log_likelihood
    return mse, loglik_error


def loglog_slope(values: np.ndarray) -> float:
    return float(np.polyfit(np.log(N_VALUES), np.log(values), 1)[0])


def test_mean_converges_to_kalman_at_rate_one_over_sqrt_n(convergence_runs):
    mse, _ = convergence_runs
    rmse = np.sqrt(mse.mean(axis=1))
    assert np.all(np.diff(rmse) < 0), rmse
    slope = loglog_slope(rmse)
    # Sampling uncertainty of the fitted slope, by bootstrap over the independent runs.
    rng = np.random.default_rng(0)
    boot = [
        loglog_slope(np.sqrt(mse[:, rng.integers(0, N_RUNS, N_RUNS)].mean(axis=1)))
        for _ in range(300)
    ]
    slope_se = float(np.std(boot))
    # Monte Carlo error of a weighted average: variance ~ 1/N, so RMSE ~ N^(-1/2).
    assert slope_se < 0.05, "too few runs to tell the slope apart"
    assert -0.5 - max(3 * slope_se, 0.1) < slope < -0.5 + max(3 * slope_se, 0.1), (slope, slope_se)


def test_likelihood_estimate_is_unbiased_and_converges(convergence_runs):
    _, loglik_error = convergence_runs
    # The particle estimate of p(z_{0:K}) is unbiased (Del Moral 2004): E[Zhat / Z] = 1.
    ratio = np.exp(loglik_error[-1])
    assert abs(ratio.mean() - 1.0) < 4 * ratio.std(ddof=1) / np.sqrt(N_RUNS)
    # Its log has a standard deviation shrinking like N^(-1/2).
    spread = loglik_error.std(axis=1, ddof=1)
    assert np.all(np.diff(spread) < 0), spread
    assert -0.75 < loglog_slope(spread) < -0.3
    assert spread[-1] < 0.25


def test_optimal_proposal_raises_ess_and_lowers_error():
    """With process noise twice the measurement noise (0.2 m vs 0.1 m), the prior is a poor proposal.

    For one observed axis, bootstrap weights exp(-(x - z)^2 / 2 r^2) with x ~ N(., q^2)
    keep only E[w]^2 / E[w^2] = r sqrt(r^2 + 2 q^2) / (r^2 + q^2) = 0.6 of the particles
    per step, about 0.6^4 = 0.13 with four axes seen; the optimal proposal's weights
    p(z_k | x_{k-1}) vary only through the small posterior spread of x_{k-1}.
    """
    scenario = quadrant_scenario().with_(Qw=0.2**2 * np.eye(6), n_samples=15)
    sim = simulate(scenario, 7)
    model = scenario.model()
    kf = kalman_filter(model, sim.measurements)
    measured = ~np.all(np.isnan(sim.measurements), axis=1)
    log_gain, boot_mse, opt_mse = [], [], []
    for seed in range(20):
        boot = ParticleFilter(model, 500, threshold=1.0).run(sim.measurements, rng=seed)
        opt = ParticleFilter(model, 500, threshold=1.0, proposal=OptimalProposal()).run(sim.measurements, rng=seed)
        log_gain.append(np.log(opt.ess[measured].mean() / boot.ess[measured].mean()))
        boot_mse.append(np.mean((boot.mean - kf.mean) ** 2))
        opt_mse.append(np.mean((opt.mean - kf.mean) ** 2))
    assert np.mean(log_gain) > 1.0  # more than e = 2.7 times the ESS
    assert np.mean(opt_mse) < 0.5 * np.mean(boot_mse)


def test_density_proposal_reproduces_the_optimal_proposal_exactly(noisy_landmarks):
    """The generic hook with q = p(x_k | x_{k-1}, z_k) gives weights p(z_k | x_{k-1}), as the analytic one."""
    model, sim, _ = noisy_landmarks

    def gaussian_parts(particles, z):
        mask, z_o, H_o, R_o = model.observed(z)
        predicted = model.predict_mean(particles)
        S = H_o @ model.Q @ H_o.T + R_o
        gain = np.linalg.solve(S, H_o @ model.Q).T
        cov = model.Q - gain @ S @ gain.T
        return predicted + (z_o - predicted @ H_o.T) @ gain.T, 0.5 * (cov + cov.T)

    def sample(particles, z, k, rng):
        mean, cov = gaussian_parts(particles, z)
        return mean + rng.standard_normal(particles.shape) @ np.linalg.cholesky(cov).T

    def log_density(new, particles, z, k):
        mean, cov = gaussian_parts(particles, z)
        return gaussian_logpdf(new - mean, cov)

    generic = ParticleFilter(model, 300, proposal=DensityProposal(sample, log_density))
    analytic = ParticleFilter(model, 300, proposal=OptimalProposal())
    a, b = generic.run(sim.measurements, rng=3), analytic.run(sim.measurements, rng=3)
    np.testing.assert_allclose(a.mean, b.mean, atol=1e-8)
    np.testing.assert_allclose(a.log_likelihood_increments, b.log_likelihood_increments, atol=1e-8)


def test_sis_never_resamples_and_threshold_one_always_does(noisy_landmarks):
    model, sim, _ = noisy_landmarks
    sis = ParticleFilter(model, 200, threshold=0.0).run(sim.measurements, rng=1)
    assert sis.n_resamples == 0
    always = ParticleFilter(model, 200, threshold=1.0).run(sim.measurements, rng=1)
    measured = ~np.all(np.isnan(sim.measurements), axis=1)
    # Weights are exactly uniform only at steps that carried no measurement since the last resampling.
    assert np.array_equal(always.resampled[measured], np.ones(measured.sum(), bool))
    half = ParticleFilter(model, 200, threshold=0.5).run(sim.measurements, rng=1)
    assert np.all(half.ess[half.resampled] < 100) and np.all(half.ess[~half.resampled] >= 100)


def test_same_seed_same_result_and_different_seed_different_result(noisy_landmarks):
    model, sim, _ = noisy_landmarks
    pf = ParticleFilter(model, 300, resampler="stratified")
    a, b, c = pf.run(sim.measurements, rng=11), pf.run(sim.measurements, rng=11), pf.run(sim.measurements, rng=12)
    for field in ("mean", "cov", "ess", "resampled", "log_likelihood_increments"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    assert not np.array_equal(a.mean, c.mean)
    gen = pf.run(sim.measurements, rng=np.random.default_rng(11))
    np.testing.assert_array_equal(gen.mean, a.mean)


def test_stored_particles_reproduce_the_reported_moments(noisy_landmarks):
    model, sim, _ = noisy_landmarks
    r = ParticleFilter(model, 100).run(sim.measurements, rng=5, collect=[Clouds()])
    assert r.particles.shape == (len(sim.measurements), 100, 6) and r.weights.shape == (len(sim.measurements), 100)
    np.testing.assert_allclose(r.weights.sum(axis=1), 1.0)
    k = 9
    np.testing.assert_allclose(r.mean[k], r.weights[k] @ r.particles[k])
    np.testing.assert_allclose(r.ess[k], 1 / np.sum(r.weights[k] ** 2))


def random_walk_model(obs_sd: float = 0.5) -> StateSpaceModel:
    return StateSpaceModel(
        dim_x=1,
        sample_initial=lambda n, rng: rng.normal(0.0, 1.0, (n, 1)),
        sample_transition=lambda x, k, rng: x + rng.normal(0.0, 0.3, x.shape),
        log_likelihood=lambda x, z, k: stats.norm.logpdf(z[0], x[:, 0], obs_sd),
    )


def test_a_model_written_in_a_few_lines_matches_its_kalman_filter():
    rng = np.random.default_rng(0)
    truth = np.cumsum(rng.normal(0, 0.3, 30)) + rng.normal()
    z = (truth + rng.normal(0, 0.5, 30))[:, None]
    z[[4, 5, 17]] = np.nan  # missing measurements
    kf = kalman_filter(LinearGaussianModel(F=[[1]], H=[[1]], m0=[0], P0=[[1]], Q=[[0.09]], R=[[0.25]]), z)
    pf = ParticleFilter(random_walk_model(), 20000).run(z, rng=1)
    # Monte Carlo error of the mean: sd ~ sqrt(P / ESS); 5 such standard errors.
    tolerance = 5 * np.sqrt(kf.cov[:, 0, 0] / pf.ess)
    assert np.all(np.abs(pf.mean[:, 0] - kf.mean[:, 0]) < tolerance)
    assert abs(pf.log_likelihood - kf.log_likelihood) < 0.1
    assert np.all(pf.log_likelihood_increments[[4, 5, 17]] == 0.0)


def test_missing_measurements_leave_weights_unchanged():
    pf = ParticleFilter(random_walk_model(), 500, threshold=0.0)
    r = pf.run([None, np.array([np.nan]), None], rng=0)
    np.testing.assert_array_equal(r.ess, [500, 500, 500])
    assert r.log_likelihood == 0.0


def test_log_domain_weights_survive_likelihoods_that_underflow():
    """A likelihood of e^-10000 is 0.0 in floating point; the log-domain filter is unaffected."""
    base = random_walk_model()
    shifted = StateSpaceModel(
        dim_x=1,
        sample_initial=base.sample_initial,
        sample_transition=base.sample_transition,
        log_likelihood=lambda x, z, k: base.log_likelihood(x, z, k) - 1e4,
    )
    z = np.array([[0.3], [0.1], [-0.2]])
    a = ParticleFilter(base, 400).run(z, rng=2)
    b = ParticleFilter(shifted, 400).run(z, rng=2)
    np.testing.assert_allclose(a.mean, b.mean, rtol=1e-9)
    np.testing.assert_allclose(b.log_likelihood_increments, a.log_likelihood_increments - 1e4)


def test_all_zero_likelihood_names_the_step():
    impossible_at_3 = StateSpaceModel(
        dim_x=1,
        sample_initial=lambda n, rng: np.zeros((n, 1)),
        sample_transition=lambda x, k, rng: x + rng.normal(size=x.shape),
        log_likelihood=lambda x, z, k: np.full(len(x), -np.inf if k == 3 else 0.0),
    )
    with pytest.raises(DegenerateWeightsError, match="step 3: every particle has zero likelihood") as info:
        ParticleFilter(impossible_at_3, 50).run(np.zeros((5, 1)), rng=0)
    assert info.value.step == 3


@pytest.mark.parametrize(
    "bad_loglik, message",
    [
        (lambda x, z, k: np.full(len(x), np.nan), "step 0: the log-likelihood is NaN or \\+inf for 10"),
        (lambda x, z, k: np.full(len(x), np.inf), "NaN or \\+inf"),
    ],
)
def test_nan_likelihood_is_a_named_error(bad_loglik, message):
    model = StateSpaceModel(1, lambda n, rng: np.zeros((n, 1)), lambda x, k, rng: x, bad_loglik)
    with pytest.raises(NumericalError, match=message):
        ParticleFilter(model, 10).run([np.zeros(1)], rng=0)


def test_model_returning_wrong_shapes_or_nan_states():
    wrong_shape = StateSpaceModel(2, lambda n, rng: np.zeros((n, 3)), lambda x, k, rng: x, lambda x, z, k: np.zeros(len(x)))
    with pytest.raises(ShapeError, match=r"step 0: sample_initial returned particles of shape \(10, 3\), expected \(10, 2\)"):
        ParticleFilter(wrong_shape, 10).run([None], rng=0)
    nan_states = StateSpaceModel(1, lambda n, rng: np.zeros((n, 1)), lambda x, k, rng: x / 0.0 * 0.0, lambda x, z, k: np.zeros(len(x)))
    with np.errstate(invalid="ignore", divide="ignore"), pytest.raises(NumericalError, match="step 1: sample_transition produced NaN"):
        ParticleFilter(nan_states, 10).run([None, None], rng=0)
    wrong_loglik = StateSpaceModel(1, lambda n, rng: np.zeros((n, 1)), lambda x, k, rng: x, lambda x, z, k: np.zeros(3))
    with pytest.raises(ShapeError, match=r"log-likelihood has shape \(3,\), expected \(10,\)"):
        ParticleFilter(wrong_loglik, 10).run([np.zeros(1)], rng=0)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"n_particles": 0}, "n_particles must be at least 1, got 0"),
        ({"n_particles": 2.5}, "n_particles must be an integer"),
        ({"n_particles": 10, "threshold": 1.5}, r"threshold must lie in \[0, 1\], got 1.5"),
        ({"n_particles": 10, "threshold": -0.1}, r"threshold must lie in \[0, 1\]"),
        ({"n_particles": 10, "resampler": "best"}, "best"),
    ],
)
def test_bad_filter_parameters(kwargs, message):
    with pytest.raises(ParameterError, match=message):
        ParticleFilter(random_walk_model(), **kwargs)


def test_landmark_measurement_of_the_wrong_length_is_a_shape_error():
    scenario = quadrant_scenario()
    sim = simulate(scenario, 0)
    with pytest.raises(ShapeError, match="z must have length 4, got 3"):
        ParticleFilter(scenario.model(), 10).run([sim.measurements[0], np.ones(3)], rng=0)
