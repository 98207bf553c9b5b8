"""ESS, weighted moments, angles, NEES, ellipses, the Gaussian log-density and the input checks."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from pfcourse import CovarianceError, DegenerateWeightsError, ParameterError, ShapeError
from pfcourse.angles import circular_mean, wrap_angle
from pfcourse.checks import check_count, check_covariance, check_probability, covariance_factor
from pfcourse.diagnostics import (
    chi2_band,
    confidence_ellipse,
    effective_sample_size,
    nees,
    normalize_log_weights,
    weighted_covariance,
    weighted_mean,
)
from pfcourse.gaussian import gaussian_logpdf


def test_ess_bounds():
    assert effective_sample_size(np.full(8, 1 / 8)) == pytest.approx(8)
    assert effective_sample_size(np.eye(8)[3]) == pytest.approx(1)
    w = np.array([0.5, 0.5, 0, 0])
    assert effective_sample_size(w) == pytest.approx(2)


def test_normalize_log_weights_in_the_log_domain():
    log_w = np.array([-1e5, -1e5 + np.log(3.0)])  # exp() of these is 0.0 in float64
    weights, log_total = normalize_log_weights(log_w)
    np.testing.assert_allclose(weights, [0.25, 0.75])
    assert log_total == pytest.approx(-1e5 + np.log(4.0))
    weights, _ = normalize_log_weights(np.array([-np.inf, 0.0, -np.inf]))
    np.testing.assert_array_equal(weights, [0, 1, 0])
    with pytest.raises(DegenerateWeightsError, match="all particle weights are zero"):
        normalize_log_weights(np.full(4, -np.inf))


def test_weighted_moments_match_numpy():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(50, 3))
    w = rng.random(50)
    w /= w.sum()
    np.testing.assert_allclose(weighted_mean(x, w), np.average(x, axis=0, weights=w))
    np.testing.assert_allclose(weighted_covariance(x, w), np.cov(x.T, aweights=w, bias=True))


def test_wrap_angle_edges():
    np.testing.assert_allclose(wrap_angle([np.pi, -np.pi, 3 * np.pi, 0.0, 2 * np.pi]), [np.pi, np.pi, np.pi, 0.0, 0.0], atol=1e-12)
    a = np.linspace(-20, 20, 1001)
    wrapped = wrap_angle(a)
    assert np.all((wrapped > -np.pi) & (wrapped <= np.pi))
    np.testing.assert_allclose(np.sin(wrapped), np.sin(a), atol=1e-12)
    np.testing.assert_allclose(np.cos(wrapped), np.cos(a), atol=1e-12)


def test_circular_mean_across_the_cut():
    near_pi = np.array([np.pi - 0.1, -np.pi + 0.1, np.pi - 0.05, -np.pi + 0.05])
    assert abs(wrap_angle(circular_mean(near_pi) - np.pi)) < 1e-12  # the arithmetic mean would be 0
    assert circular_mean(np.array([0.1, 0.3]), np.array([0.75, 0.25])) == pytest.approx(
        np.arctan2(0.75 * np.sin(0.1) + 0.25 * np.sin(0.3), 0.75 * np.cos(0.1) + 0.25 * np.cos(0.3))
    )
    assert np.isnan(circular_mean(np.array([0.0, np.pi])))  # no defined direction


def test_weighted_moments_of_an_angle_component():
    x = np.array([[0.0, np.pi - 0.1], [1.0, -np.pi + 0.1]])
    w = np.array([0.5, 0.5])
    mean = weighted_mean(x, w, angle_indices=[1])
    assert abs(wrap_angle(mean[1] - np.pi)) < 1e-12
    cov = weighted_covariance(x, w, mean, angle_indices=[1])
    assert cov[1, 1] == pytest.approx(0.01)  # deviations of +/-0.1 rad, not +/-(pi - 0.1)


def test_nees_of_a_consistent_estimator_is_chi_square():
    rng = np.random.default_rng(1)
    d, k = 3, 4000
    a = rng.normal(size=(d, d))
    cov = a @ a.T + d * np.eye(d)
    errors = rng.multivariate_normal(np.zeros(d), cov, size=k)
    values = nees(errors, np.zeros((k, d)), np.broadcast_to(cov, (k, d, d)))
    lo, hi = chi2_band(d, n_runs=k, probability=0.999)
    assert lo < values.mean() < hi
    assert stats.kstest(values, stats.chi2(d).cdf).pvalue > 1e-3


def test_chi2_band_against_scipy():
    lo, hi = chi2_band(2, n_runs=1, probability=0.95)
    assert (lo, hi) == pytest.approx((stats.chi2.ppf(0.025, 2), stats.chi2.ppf(0.975, 2)))
    lo50, hi50 = chi2_band(2, n_runs=50)
    assert lo < lo50 < 2 < hi50 < hi


def test_nees_shape_errors():
    with pytest.raises(ShapeError, match="nees needs"):
        nees(np.zeros((5, 2)), np.zeros((5, 3)), np.zeros((5, 2, 2)))


def test_confidence_ellipse_covers_its_probability():
    cov = np.array([[2.0, 1.2], [1.2, 1.0]])
    centre, width, height, angle = confidence_ellipse([1.0, -1.0], cov, 0.9)
    rng = np.random.default_rng(2)
    pts = rng.multivariate_normal(centre, cov, size=20000) - centre
    t = np.radians(angle)
    u = pts @ np.array([np.cos(t), np.sin(t)])
    v = pts @ np.array([-np.sin(t), np.cos(t)])
    inside = (u / (width / 2)) ** 2 + (v / (height / 2)) ** 2 <= 1
    # binomial standard error sqrt(0.9 * 0.1 / 20000) = 0.0021; 5 of them
    assert abs(inside.mean() - 0.9) < 0.011
    assert width >= height


def test_gaussian_logpdf_matches_scipy():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(4, 4))
    cov = a @ a.T + np.eye(4)
    r = rng.normal(size=(100, 4))
    np.testing.assert_allclose(gaussian_logpdf(r, cov), stats.multivariate_normal(np.zeros(4), cov).logpdf(r))
    with pytest.raises(CovarianceError, match="not positive definite"):
        gaussian_logpdf(r[:, :2], np.zeros((2, 2)))


@pytest.mark.parametrize(
    "matrix, message",
    [
        ([[1.0, 0.5], [0.0, 1.0]], "P is not symmetric"),
        ([[1.0, 2.0], [2.0, 1.0]], "P is not positive semi-definite"),
        ([[1.0, 0.0, 0.0]], "P must be square"),
        ([[np.nan, 0.0], [0.0, 1.0]], "P contains NaN"),
    ],
)
def test_bad_covariances(matrix, message):
    with pytest.raises(CovarianceError, match=message):
        check_covariance(matrix, "P")


def test_covariance_checks_accept_semidefinite_and_can_demand_definite():
    singular = np.diag([1.0, 0.0])
    np.testing.assert_array_equal(check_covariance(singular, "Q"), singular)
    with pytest.raises(CovarianceError, match="R is not positive definite"):
        check_covariance(singular, "R", definite=True)
    with pytest.raises(ShapeError, match=r"must have shape \(3, 3\)"):
        check_covariance(np.eye(2), "Q", 3)
    factor = covariance_factor(singular)
    np.testing.assert_allclose(factor @ factor.T, singular)


def test_scalar_checks():
    assert check_probability(0.0, "t") == 0.0 and check_probability(1, "t") == 1.0
    with pytest.raises(ParameterError, match=r"t must lie in \[0, 1\], got nan"):
        check_probability(float("nan"), "t")
    with pytest.raises(ParameterError, match="N must be at least 1"):
        check_count(0, "N")
    with pytest.raises(ParameterError, match="N must be an integer"):
        check_count(True, "N")


def test_nees_of_a_collapsed_cloud_is_infinite_not_an_error():
    truth = np.array([[1.0, 2.0], [0.0, 0.0]])
    estimate = np.array([[1.5, 2.0], [0.5, 0.0]])
    cov = np.array([np.eye(2), np.zeros((2, 2))])  # step 1: all weight on one particle
    values = nees(truth, estimate, cov)
    assert values[0] == pytest.approx(0.25) and values[1] == np.inf


def test_nees_of_a_cloud_collapsed_in_some_directions_is_infinite_never_round_off():
    """A covariance singular to working precision (rank 1 here, from a cloud on a line, plus
    round-off) must not count as covering the truth: a direct solve returns round-off."""
    rng = np.random.default_rng(0)
    along = rng.standard_normal(50)
    cloud = np.column_stack([along, 0.3 * along + 1e-17 * rng.standard_normal(50)])
    cov = np.cov(cloud.T, bias=True)
    err = np.array([[0.0, 0.5]])  # off the line: the filter claims it impossible
    values = nees(err, np.zeros((1, 2)), cov[None])
    assert values[0] == np.inf or values[0] > 1e20
    stack = np.array([np.eye(2), cov])  # batched and step-by-step paths agree
    assert nees(np.vstack([err, err]), np.zeros((2, 2)), stack)[0] == pytest.approx(0.25)


def test_nees_of_a_nearly_collapsed_cloud_is_infinite_without_warnings():
    truth = np.array([[1.0, 0.0]])
    cov = np.array([[[1e-320, 0.0], [0.0, 1e-320]]])  # its inverse overflows
    assert nees(truth, np.zeros((1, 2)), cov)[0] == np.inf
    assert np.isnan(nees(np.array([[np.nan, 0.0]]), np.zeros((1, 2)), np.eye(2)[None]))[0]
