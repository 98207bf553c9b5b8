"""Issue 42 on terrain navigation: the field's 2-D point-mass filter and the map-bias state, each
against an exact answer (a Kalman filter where the model is linear), and the remedies' arithmetic."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import norm

from pfcourse.collectors import Clouds
from pfcourse.errors import ParameterError
from pfcourse.filter import ParticleFilter
from pfcourse.scenarios.terrain.field import FieldModel, FieldPointMass, FieldScenario, simulate_field
from pfcourse.scenarios.terrain.map import TerrainMap, mismatched_map
from pfcourse.scenarios.terrain.map_bias import (MapBiasTerrainModel, bias_kalman_update, correlation_length, inflated_rf,
                                       map_bias_filter, readings_per_length)
from pfcourse.scenarios.terrain.scenario import AircraftScenario

# A tilted plane: h(x, y) = 100 + 0.05 x - 0.03 y is linear, and bilinear interpolation of a plane is exact,
# so the 2-D problem on it is linear-Gaussian and the Kalman filter is its exact posterior.
_NX, _NY, _D = 120, 120, 100.0
_xs, _ys = np.meshgrid(np.arange(_NX) * _D, np.arange(_NY) * _D)
PLANE = TerrainMap(100.0 + 0.05 * _xs - 0.03 * _ys, dx=_D, dy=_D)
SMALL = FieldScenario(duration=20.0, x0=np.array([5000.0, 6000.0]), sd0=300.0, drift=3.0, R=5.0**2)
GRAD = np.array([0.05, -0.03])


def _kalman(scenario: FieldScenario, readings):
    """Exact posterior mean and covariance of p_k for the plane."""
    m, P = scenario.x0.copy(), scenario.sd0**2 * np.eye(2)
    u = scenario.displacements
    means, covs = [m.copy()], [P.copy()]
    for k in range(1, scenario.n_steps):
        m, P = m + u[k], P + scenario.drift**2 * scenario.dt * np.eye(2)
        S = GRAD @ P @ GRAD + scenario.R
        K = P @ GRAD / S
        m = m + K * (readings[k] - (100.0 + GRAD @ m))
        P = P - np.outer(K, K) * S
        means.append(m.copy())
        covs.append(P.copy())
    return np.array(means), np.array(covs)


def test_the_point_mass_filter_on_a_plane_is_the_kalman_filter_to_a_fraction_of_a_cell():
    flight = simulate_field(SMALL, PLANE, np.random.default_rng(5))
    m, P = _kalman(SMALL, flight.readings)
    for cell in (10.0, 5.0):
        res = FieldPointMass(PLANE, SMALL, cell=cell).run(flight.readings)
        # a lattice approximates the Gaussian to O(cell^2) in its moments: far below a cell at these sizes
        assert np.abs(res.mean - m).max() < 0.1 * cell
        assert np.allclose(res.sd, np.sqrt(np.stack([P[:, 0, 0], P[:, 1, 1]], axis=1)), rtol=0.02)


def test_the_bootstrap_filter_of_the_field_problem_agrees_with_the_kalman_filter():
    flight = simulate_field(SMALL, PLANE, np.random.default_rng(6))
    m, P = _kalman(SMALL, flight.readings)
    pf = ParticleFilter(FieldModel(PLANE, SMALL), 20000, threshold=0.5, resampler="systematic")
    res = pf.run(flight.readings[:, None], rng=7)
    # Monte Carlo error of a weighted mean with ESS >= N/2 is about sd / sqrt(N/2); 6 of those is generous
    sd = np.sqrt(P[-1, [0, 1], [0, 1]])
    assert np.all(np.abs(res.mean[-1] - m[-1]) < 6 * sd / np.sqrt(10000) + 1.0)


def test_simulate_field_draws_from_the_generator_it_is_given():
    state = np.random.get_state()
    a = simulate_field(SMALL, PLANE, np.random.default_rng(1))
    b = simulate_field(SMALL, PLANE, np.random.default_rng(1))
    c = simulate_field(SMALL, PLANE, np.random.default_rng(2))
    assert np.array_equal(a.truth, b.truth) and not np.allclose(a.truth, c.truth)
    assert np.isnan(a.readings[0]) and np.all(np.isfinite(a.readings[1:]))
    after = np.random.get_state()
    assert state[0] == after[0] and np.array_equal(state[1], after[1])


def test_the_field_scenario_and_grid_refuse_bad_input():
    with pytest.raises(ParameterError, match="drift"):
        FieldScenario(drift=0.0)
    with pytest.raises(ParameterError, match="x0"):
        FieldScenario(x0=np.array([1.0, np.nan]))
    with pytest.raises(ParameterError, match="cell"):
        FieldPointMass(PLANE, SMALL, cell=-1.0)
    with pytest.raises(ParameterError, match="lattice points"):
        FieldPointMass(PLANE, SMALL.with_(sd0=1e5), cell=1.0)


def test_the_bias_update_is_the_two_state_kalman_update():
    rng = np.random.default_rng(0)
    m = np.column_stack([1500.0 + rng.normal(0, 5, 4), rng.normal(0, 3, 4)])
    A = rng.normal(size=(4, 2, 2))
    cov = A @ A.transpose(0, 2, 1) * 50.0 + np.eye(2) * 10.0
    P = np.column_stack([cov[:, 0, 0], cov[:, 0, 1], cov[:, 1, 1]])
    ground = np.array([240.0, 260.0, 250.0, np.nan])
    m_new, P_new, log_lik = bias_kalman_update(m, P, ground, 1250.0, 400.0)
    H = np.array([1.0, 1.0])
    for i in range(3):
        S = H @ cov[i] @ H + 400.0
        K = cov[i] @ H / S
        nu = 1250.0 - (H @ m[i] - ground[i])
        assert np.allclose(m_new[i], m[i] + K * nu, rtol=1e-13)
        full = cov[i] - np.outer(K, K) * S
        assert np.allclose(P_new[i], [full[0, 0], full[0, 1], full[1, 1]], rtol=1e-10, atol=1e-9)
        assert np.isclose(log_lik[i], norm.logpdf(nu, 0.0, np.sqrt(S)), rtol=1e-13)
    assert log_lik[3] == -np.inf and np.array_equal(m_new[3], m[3])


FLAT = TerrainMap(np.full((60, 60), 250.0), dx=1000.0, dy=1000.0)
SHORT = AircraftScenario(duration=20.0, x0=np.array([30000.0, 30000.0, 1500.0, 0.3]),
                         P0=np.diag([300.0, 300.0, 100.0, 0.1]) ** 2)


def test_on_a_flat_map_every_particle_is_the_two_state_kalman_filter():
    """On a flat map the path does not matter: each particle's (z, b) filter is one textbook Kalman filter."""
    rng = np.random.default_rng(3)
    readings = 1500.0 - 250.0 + 20.0 * rng.standard_normal(SHORT.n_steps)
    readings[0] = np.nan
    sd_b, length = 12.0, 300.0
    res = map_bias_filter(FLAT, SHORT, 40, sd_b, length, threshold=0.5).run(readings[:, None], rng=4,
                                                                           collect=[Clouds()])
    a = np.exp(-SHORT.speed * SHORT.dt / length)
    F, Q = np.diag([1.0, a]), np.diag([SHORT.Qf[2, 2] * SHORT.dt, sd_b**2 * (1 - a * a)])
    m, P, H = np.array([1500.0, 0.0]), np.diag([100.0**2, sd_b**2]), np.array([1.0, 1.0])
    for k in range(1, SHORT.n_steps):
        m, P = F @ m, F @ P @ F.T + Q
        S = H @ P @ H + SHORT.Rf
        K = P @ H / S
        m, P = m + K * (readings[k] + 250.0 - H @ m), P - np.outer(K, K) * S
        assert np.allclose(res.particles[k, :, 2], m[0], rtol=1e-12)
        assert np.allclose(res.particles[k, :, 4], m[1], rtol=1e-9, atol=1e-9)
        assert np.allclose(res.particles[k, :, [5, 6, 7]].T, [P[0, 0], P[0, 1], P[1, 1]], rtol=1e-9, atol=1e-9)


def test_the_bias_model_refuses_a_non_positive_spread_or_length():
    with pytest.raises(ParameterError, match="map_sd and length"):
        MapBiasTerrainModel(FLAT, SHORT, 0.0, 300.0)
    with pytest.raises(ParameterError, match="map_sd and length"):
        MapBiasTerrainModel(FLAT, SHORT, 12.0, -1.0)


def test_the_inflation_counts_the_readings_per_correlation_length():
    sc = AircraftScenario()
    assert readings_per_length(sc, 335.0) == pytest.approx(3.35)
    assert readings_per_length(sc.with_(measurement_period=0.1, dt=0.1), 335.0) == pytest.approx(33.5)
    assert readings_per_length(sc.with_(measurement_period=10.0), 335.0) == 1.0  # never below one reading
    assert inflated_rf(sc, 12.0, 335.0) == pytest.approx(sc.Rf + 3.35 * 144.0)


def test_the_correlation_length_is_where_the_map_error_s_correlation_falls_to_one_over_e():
    """mismatched_map's error field, Gaussian-smoothed white noise: correlation exp(-d^2 / (4 c^2)) at d cells."""
    terrain = TerrainMap(np.zeros((200, 200)), dx=80.0, dy=80.0)
    e = mismatched_map(terrain, np.random.default_rng(0), smoothing=0.0).heights
    c = 2.0
    length = correlation_length(terrain, c)
    lag = int(round(length / 80.0))  # 4 cells: the 1/e distance
    corr = np.mean(e[:, :-lag] * e[:, lag:]) / np.var(e)
    assert corr == pytest.approx(np.exp(-1.0), abs=0.05)
