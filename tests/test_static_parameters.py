"""pfcourse.static_parameters: the exact grid posterior, the three online samplers, and the exercise's checker.

The exact properties used: when the state is known (``P_0 = 0``, ``Q = 0``) the posterior of the noise
scale is exactly ``IG(a_0 + n / 2, b_0 + S / 2)``; the sufficient-statistic filter is then exact for any
``N`` (every particle carries the same statistic), and SMC²'s inner filters return the exact
likelihood, so SMC² is an importance sampler whose error shrinks like ``1 / sqrt(N_theta)``.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from pfcourse import LinearGaussianModel, ParameterError, ShapeError
from pfcourse.static_parameters import (InverseGamma, NoiseScaleProblem, liu_west, smc2, sufficient_statistic_filter,
                                        systematic_rows)

PRIOR = InverseGamma(3.0, 2.0)


def known_state_problem(K=40, seed=0, theta=1.5):
    """x_k = 1 for every k (no noise), z_k = (x, 2x) + N(0, theta diag(0.5, 2)); x_0's row unmeasured."""
    model = LinearGaussianModel(F=[[1.0]], H=[[1.0], [2.0]], m0=[1.0], P0=[[0.0]], Q=[[0.0]], R=np.diag([0.5, 2.0]))
    rng = np.random.default_rng(seed)
    Z = np.array([1.0, 2.0]) + rng.standard_normal((K, 2)) * np.sqrt(theta * np.array([0.5, 2.0]))
    Z[0] = np.nan
    Z[K // 2, 1] = np.nan  # one missing coordinate
    problem = NoiseScaleProblem(model, PRIOR)
    resid = (Z - np.array([1.0, 2.0])) ** 2 / np.array([0.5, 2.0])
    a = PRIOR.shape + np.sum(~np.isnan(Z)) / 2
    b = PRIOR.scale + np.nansum(resid) / 2
    return problem, Z, stats.invgamma(a, scale=b)


def test_the_grid_posterior_is_the_conjugate_one_when_the_state_is_known():
    problem, Z, exact = known_state_problem()
    grid = problem.exact_posterior(Z, np.linspace(np.log(0.3), np.log(6.0), 801))
    assert grid.mean == pytest.approx(exact.mean(), rel=1e-5)
    assert grid.sd == pytest.approx(exact.std(), rel=1e-4)
    # the evidence: p(z) = p(z | theta) p(theta) / p(theta | z) at any theta
    t = 1.3
    log_evidence = problem.kalman_log_likelihood(Z, t) + PRIOR.logpdf(t) - exact.logpdf(t)
    assert grid.log_evidence == pytest.approx(log_evidence, abs=1e-6)


def test_the_sufficient_statistic_filter_is_exact_when_the_state_is_known():
    problem, Z, exact = known_state_problem()
    result = sufficient_statistic_filter(problem, Z, 50, np.random.default_rng(3))
    assert result.mean == pytest.approx(exact.mean(), rel=1e-12)
    assert result.sd == pytest.approx(exact.std(), rel=1e-10)
    assert result.extra["ancestors_of_first_step"] >= 1 and result.evaluations == 50 * (len(Z) - 1)


def test_smc2_with_exact_inner_likelihoods_is_within_its_importance_sampling_error():
    problem, Z, exact = known_state_problem()
    n_theta = 4000
    result = smc2(problem, Z, n_theta, 2, np.random.default_rng(5))
    # independent draws would give sd / sqrt(N_theta); resampling and moves at most double the variance here
    assert abs(result.mean - exact.mean()) < 5 * exact.std() * np.sqrt(2 / n_theta)
    assert result.sd == pytest.approx(exact.std(), rel=0.1)
    assert result.extra["moves"] and 0 < np.mean(result.extra["acceptance"]) < 1
    # log evidence: exact inner likelihoods, so only the theta-sampler's error
    grid = problem.exact_posterior(Z, np.linspace(np.log(0.3), np.log(6.0), 801))
    assert result.extra["log_evidence"] == pytest.approx(grid.log_evidence, abs=0.05)


def test_liu_west_without_kernel_is_importance_sampling_from_the_prior():
    problem, Z, exact = known_state_problem(K=6)  # few data: the prior's draws still cover the posterior
    n = 20000
    result = liu_west(problem, Z[:2], n, np.random.default_rng(1), delta=1.0)  # one measured step: no resampling
    theta = result.theta
    # one step with delta = 1: the self-normalised estimate from prior draws; its error ~ sd / sqrt(ESS)
    W = np.exp(result.log_weights)
    posterior = stats.invgamma(PRIOR.shape + 1.0, scale=PRIOR.scale + np.sum((Z[1] - [1.0, 2.0]) ** 2 / [0.5, 2.0]) / 2)
    assert abs(W @ theta - posterior.mean()) < 5 * posterior.std() / np.sqrt(1 / np.sum(W**2))


def test_the_samplers_draw_only_from_the_generator_they_are_given():
    problem, Z, _ = known_state_problem(K=10)
    state = np.random.get_state()
    for run in (lambda rng: liu_west(problem, Z, 20, rng), lambda rng: sufficient_statistic_filter(problem, Z, 20, rng),
                lambda rng: smc2(problem, Z, 10, 5, rng)):
        one, again, other = run(np.random.default_rng(1)), run(np.random.default_rng(1)), run(np.random.default_rng(2))
        assert np.array_equal(one.theta, again.theta) and not np.array_equal(one.theta, other.theta)
    assert all(np.array_equal(a, b) for a, b in zip(state[1:2], np.random.get_state()[1:2]))


def test_systematic_rows_gives_each_particle_floor_or_ceil_of_n_w_copies():
    rng = np.random.default_rng(0)
    log_w = rng.normal(0, 2, (50, 30))
    idx = systematic_rows(log_w, rng)
    W = np.exp(log_w - log_w.max(axis=1, keepdims=True))
    W /= W.sum(axis=1, keepdims=True)
    for row, w in zip(idx, W):
        counts = np.bincount(row, minlength=30)
        assert np.all(counts >= np.floor(30 * w - 1e-9)) and np.all(counts <= np.ceil(30 * w + 1e-9))


def test_bad_input_gets_a_named_error_when_the_object_is_built():
    model = LinearGaussianModel(F=[[1.0]], H=[[1.0], [1.0]], m0=[0.0], P0=[[1.0]], Q=[[1.0]],
                                R=[[1.0, 0.5], [0.5, 1.0]])
    with pytest.raises(ParameterError, match="diagonal"):
        NoiseScaleProblem(model, PRIOR)
    with pytest.raises(ParameterError, match="shape"):
        InverseGamma(0.0, 1.0)
    with pytest.raises(ParameterError, match="InverseGamma"):
        NoiseScaleProblem(known_state_problem()[0].model, (3.0, 2.0))
    problem, Z, _ = known_state_problem(K=5)
    with pytest.raises(ShapeError):
        sufficient_statistic_filter(problem, Z[:, :1], 10, np.random.default_rng(0))
    with pytest.raises(ParameterError, match="n must be"):
        liu_west(problem, Z, 1, np.random.default_rng(0))
    with pytest.raises(ParameterError, match="delta"):
        liu_west(problem, Z, 10, np.random.default_rng(0), delta=1.5)
    with pytest.raises(ParameterError, match="ess_threshold"):
        smc2(problem, Z, 10, 10, np.random.default_rng(0), ess_threshold=0.0)


# --- the exercise: check_storvik_step --------------------------------------------------------------

def student_step(x, a, b, z, rng, mistake=None):
    """A student's Storvik step for the random walk's process-noise variance, typical mistakes as switches."""
    from pfcourse.book.exercises import STORVIK_R as r

    if mistake == "mean_theta":
        theta = b / (a - 1)
    elif mistake == "gamma":
        theta = rng.gamma(a, 1 / b)
    elif mistake == "one_theta":
        theta = b[0] / rng.gamma(a, 1.0)
    else:
        theta = b / rng.gamma(a, 1.0, x.shape)
    scale = theta if mistake == "theta_as_sd" else np.sqrt(theta)
    x_new = x + scale * rng.standard_normal(x.shape)
    log_w = stats.norm.logpdf(z, x_new, r if mistake == "variance_as_sd" else np.sqrt(r))
    a_new = a + (1.0 if mistake == "a_whole" else 0.5)
    if mistake == "no_half":
        b_new = b + (x_new - x) ** 2
    elif mistake == "measurement_residual":
        b_new = b + (z - x_new) ** 2 / 2
    else:
        b_new = b + (x_new - x) ** 2 / 2
    return x_new, a_new, b_new, log_w


def test_the_reference_storvik_step_passes():
    from pfcourse.book.exercises import check_storvik_step, storvik_step_reference

    assert check_storvik_step(storvik_step_reference).ok
    report = check_storvik_step(student_step)
    assert report.ok, str(report)


@pytest.mark.parametrize("mistake, says", [
    ("a_whole", "gains 1/2 per step"),
    ("no_half", "the 1/2 is missing"),
    ("measurement_residual", "not from the measurement residuals"),
    ("variance_as_sd", "reads the variance r as a standard deviation"),
    ("mean_theta", "posterior mean b / (a - 1)"),
    ("gamma", "drawn from a gamma"),
    ("theta_as_sd", "uses theta as a standard deviation"),
    ("one_theta", "one theta is drawn for every particle"),
])
def test_each_typical_storvik_mistake_gets_its_own_sentence(mistake, says):
    from pfcourse.book.exercises import check_storvik_step

    report = check_storvik_step(lambda *args: student_step(*args, mistake=mistake))
    assert not report.ok and len(report.problems) == 1
    assert says in report.problems[0], report.problems[0]


def test_the_storvik_checker_checks_the_generator_and_odd_answers():
    from pfcourse.book.exercises import check_storvik_step

    state = np.random.get_state()
    assert "rng it is given is not used" in str(check_storvik_step(
        lambda x, a, b, z, rng: student_step(x, a, b, z, np.random.default_rng(0))))

    def global_draws(x, a, b, z, rng):
        np.random.standard_normal()
        return student_step(x, a, b, z, rng)

    assert "global np.random" in str(check_storvik_step(global_draws))
    assert np.array_equal(state[1], np.random.get_state()[1])
    assert "returned None" in str(check_storvik_step(lambda *args: None))
    assert "four things" in str(check_storvik_step(lambda *args: student_step(*args)[:3]))
    assert "raised ZeroDivisionError" in str(check_storvik_step(lambda *args: 1 / 0))
