"""The compiled loops (pfcourse.kernels, the robot's kernels) against their NumPy definitions.

Bit for bit where the kernel promises it (summation in NumPy's order, weights, resampled
indices, the robot's motion); to rounding where it sums in another order (moments) or
uses another formula for the same number (the range as sqrt instead of hypot).
"""

import numpy as np
import pytest
from scipy.special import logsumexp

from pfcourse.collectors import Clouds
from pfcourse import arithmetic, kernels
from pfcourse.angles import wrap_angle
from pfcourse.diagnostics import (
    effective_sample_size,
    normalize_log_weights,
    weighted_covariance,
    weighted_mean,
)
from pfcourse.filter import ParticleFilter
from pfcourse.resampling import multinomial, residual, stratified, systematic
from pfcourse.scenarios.robot.scenario import (
    R_TRUE,
    RobotModel,
    _log_likelihood,
    _move_diagonal,
    motion,
    range_bearing,
    simulate_robot,
)
from test_fast_paths import log_weight_vectors


# NumPy computes with the pinned code paths here (on the platforms that reproduce the book:
# tests/test_arithmetic.py fails if the pinning is lost), whatever this CPU would choose itself.
PINNED = arithmetic.reproduces_stored_outputs() and arithmetic.runtime_arithmetic().is_pinned


def same_floats(got, expected) -> bool:
    """Bit for bit where NumPy's transcendental functions are the C library's (its pinned AVX2
    paths, pfcourse.arithmetic); to a few ulps elsewhere (other SIMD paths, e.g. AVX-512 or
    ARM's, round them differently from the libm calls of the compiled kernels)."""
    if PINNED:
        return np.array_equal(got, expected)
    return np.allclose(got, expected, rtol=8 * np.finfo(float).eps, atol=0.0)


def test_pairwise_sum_is_numpys_sum_to_the_bit():
    rng = np.random.default_rng(0)
    sizes = list(range(0, 300)) + [int(n) for n in rng.integers(300, 200_000, 60)]
    for n in sizes:
        a = rng.standard_normal(n) * 10.0 ** rng.integers(-8, 8) + rng.uniform(-5, 5)
        assert kernels.pairwise_sum(a) == np.sum(a), n


def test_a_plain_running_sum_would_not_be():
    """The test above can fail: a left-to-right sum differs from NumPy's on most long vectors."""
    a = np.random.default_rng(1).standard_normal(10_000) * 1e3
    assert float(np.cumsum(a)[-1]) != np.sum(a)


def test_normalize_step_gives_the_floats_of_the_numpy_definitions():
    for a in log_weight_vectors(1500, seed=2):
        if not np.isfinite(a.max()):
            continue
        previous = np.random.default_rng(a.size).uniform(-3.0, 0.0, a.size)
        log_weights, weights, scratch = previous.copy(), np.empty(a.size), np.empty(a.size)
        total, ess = kernels.normalize_step(log_weights, a, weights, scratch)
        expected_w, expected_total = normalize_log_weights(previous + a)
        assert same_floats(total, expected_total) and same_floats(total, float(logsumexp(previous + a)))
        assert same_floats(weights, expected_w)
        assert same_floats(log_weights, previous + a - expected_total)
        assert ess == effective_sample_size(expected_w) == 1.0 / np.sum(expected_w**2)


def test_normalize_step_reports_zero_weights():
    lw, w, s = np.zeros(4), np.empty(4), np.empty(4)
    assert kernels.normalize_step(lw, np.full(4, -np.inf), w, s)[0] == -np.inf


@pytest.mark.parametrize("angles", [(), (2,), (0, 2)])
def test_weighted_moments_agree_with_the_numpy_definitions(angles):
    rng = np.random.default_rng(3)
    is_angle = np.zeros(3, dtype=bool)
    is_angle[list(angles)] = True
    for n in (1, 2, 7, 100, 5000):
        x = rng.standard_normal((n, 3)) * [1.0, 30.0, 0.5]
        x[:, 2] += np.pi - 0.2  # a cloud across the +/- pi cut
        x[:, list(angles)] = wrap_angle(x[:, list(angles)])
        w = rng.exponential(size=n)
        w /= w.sum()
        mean, cov = kernels.weighted_moments(x, w, is_angle)
        expected_mean = weighted_mean(x, w, angles)
        np.testing.assert_allclose(mean, expected_mean, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(cov, weighted_covariance(x, w, expected_mean, angles), rtol=1e-11, atol=1e-14)
        assert np.array_equal(cov, cov.T)


def test_a_collapsed_cloud_has_its_point_as_mean_and_zero_covariance():
    x = np.tile([1.1, -50.3, 0.7], (1000, 1))
    w = np.random.default_rng(12).dirichlet(np.ones(1000))
    mean, cov = kernels.weighted_moments(x, w, np.array([False, False, True]))
    assert np.array_equal(mean[:2], x[0, :2]) and np.all(cov == 0.0)


def test_circular_mean_of_evenly_spread_angles_is_nan_in_both():
    x = np.zeros((4, 3))
    x[:, 2] = [0.0, np.pi / 2, np.pi, -np.pi / 2]
    w = np.full(4, 0.25)
    mean, _ = kernels.weighted_moments(x, w, np.array([False, False, True]))
    assert np.isnan(mean[2]) and np.isnan(weighted_mean(x, w, (2,))[2])


def reference_inverse_cdf(w, u):
    """The searchsorted definition the merge pass replaces."""
    cdf = np.minimum(np.cumsum(w), 1.0)
    cdf[np.flatnonzero(w)[-1]:] = 1.0
    return np.searchsorted(cdf, np.minimum(u, np.nextafter(1.0, 0.0)), side="right")


def test_inverse_cdf_merge_gives_the_searchsorted_indices():
    rng = np.random.default_rng(4)
    for t in range(400):
        n = int(rng.integers(1, 3000))
        w = rng.exponential(size=n) ** rng.uniform(1, 8)
        w[rng.random(n) < 0.3 * (t % 3)] = 0.0  # zero weights, sometimes at the end
        if not w.any():
            w[0] = 1.0
        w /= w.sum()
        u = np.sort(rng.random(int(rng.integers(1, 3000))))
        if t % 7 == 0:
            u[-1] = 1.0  # never past the end
        got = kernels.inverse_cdf_sorted(w, u)
        assert np.array_equal(got, reference_inverse_cdf(w, u))
        assert np.all(w[got] > 0)


@pytest.mark.parametrize("scheme", [multinomial, stratified, systematic, residual])
def test_resamplers_draw_the_indices_of_the_searchsorted_definition(scheme):
    w = np.random.default_rng(5).dirichlet(np.full(500, 0.3))
    got = scheme(w, np.random.default_rng(6))
    rng = np.random.default_rng(6)
    if scheme is multinomial:
        expected = np.sort(reference_inverse_cdf(w, rng.random(500)))
    elif scheme is stratified:
        expected = reference_inverse_cdf(w, (np.arange(500) + rng.random(500)) / 500)
    elif scheme is systematic:
        expected = reference_inverse_cdf(w, (np.arange(500) + rng.random()) / 500)
    else:
        expected = got  # residual: checked by its offspring-count tests in test_resampling.py
    assert np.array_equal(got, expected)


def test_small_helpers_match_numpy():
    rng = np.random.default_rng(13)
    for n in (1, 5, 130, 10_000):
        a = rng.exponential(size=n)
        assert kernels.sum_of_squares(a) == np.sum(a**2)
        assert kernels.finite_minimum(a) == (True, a.min())
        a[n // 2] = np.nan
        assert not kernels.finite_minimum(a)[0]
        a[n // 2] = -np.inf
        assert not kernels.finite_minimum(a)[0]


def test_gather_rows_is_fancy_indexing():
    x = np.random.default_rng(7).standard_normal((50, 3))
    idx = np.random.default_rng(8).integers(0, 50, 80)
    assert np.array_equal(kernels.gather_rows(x, idx), x[idx])


def test_robot_motion_kernel_is_motion_to_the_bit():
    sim = simulate_robot(rng=1, n_steps=5)
    rng = np.random.default_rng(9)
    x = np.column_stack([rng.uniform(-60, 60, (4000, 2)), rng.uniform(-np.pi, np.pi, 4000)])
    q_std = np.array([0.03, 0.02, 0.05])
    for k in range(1, 5):
        noise = rng.standard_normal((4000, 3))
        expected = motion(x, noise * q_std + sim.odometry[k], 1.5)
        assert same_floats(_move_diagonal(x, noise, sim.odometry[k], q_std, 1.5), expected)


def test_robot_likelihood_kernel_is_the_gaussian_of_the_wrapped_innovation():
    rng = np.random.default_rng(10)
    x = np.column_stack([rng.uniform(-60, 60, (4000, 2)), rng.uniform(-np.pi, np.pi, 4000)])
    landmark, z = np.array([3.0, -7.0]), np.array([20.0, 3.1])  # bearing near the cut
    r = 2.0 * R_TRUE
    nu = z - range_bearing(x, landmark)
    nu[:, 1] = wrap_angle(nu[:, 1])
    expected = -np.log(2 * np.pi) - 0.5 * np.log(np.linalg.det(r)) - 0.5 * np.einsum(
        "ij,jk,ik->i", nu, np.linalg.inv(r), nu
    )
    a = np.linalg.inv(np.linalg.cholesky(r))
    log_norm = -np.log(2 * np.pi) - np.sum(np.log(np.diag(np.linalg.cholesky(r))))
    got = _log_likelihood(x, landmark[0], landmark[1], z[0], z[1], a[0, 0], a[1, 0], a[1, 1], log_norm)
    np.testing.assert_allclose(got, expected, rtol=1e-12)


def test_filter_moments_match_the_numpy_moments_of_the_stored_cloud():
    sim = simulate_robot(rng=2, n_steps=30)
    model = RobotModel.for_simulation(sim)
    result = ParticleFilter(model, 500).run(sim.measurements, 11, collect=[Clouds()])
    for k in range(30):
        mean = weighted_mean(result.particles[k], result.weights[k], (2,))
        np.testing.assert_allclose(result.mean[k], mean, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(
            result.cov[k], weighted_covariance(result.particles[k], result.weights[k], mean, (2,)),
            rtol=1e-10, atol=1e-15,
        )
        assert result.ess[k] == effective_sample_size(result.weights[k])
