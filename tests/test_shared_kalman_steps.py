"""The Kalman steps the association filters and the terrain filters share (one function each).

association: the chi-square gate, the innovation distance and the Joseph-form update that the
nearest-neighbour EKF and the PDA filter both use; terrain: the horizontal move, the altimeter's
innovation and its log predictive density that the marginalised and the map-bias filters both use.
Each is checked against the textbook formula computed another way.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from pfcourse.errors import ParameterError
from pfcourse.scenarios.robot.association import gate_threshold, innovation_distance, joseph_update
from pfcourse.scenarios.terrain.marginalised import altimeter_innovation, innovation_log_density


def _spd(rng: np.random.Generator, d: int) -> np.ndarray:
    a = rng.normal(size=(d, d))
    return a @ a.T + d * np.eye(d)


@pytest.mark.parametrize("p, dim", [(0.99, 2), (0.9, 1), (0.5, 3)])
def test_the_gate_holds_its_probability_of_a_correct_reading(p, dim):
    gamma = gate_threshold(p, dim)
    assert stats.chi2.cdf(gamma, dim) == pytest.approx(p, abs=1e-12)
    d2 = np.sum(np.random.default_rng(dim).standard_normal((200_000, dim)) ** 2, axis=1)
    # the share of correct readings inside the gate: binomial standard error below 0.0012 at n = 200 000
    assert np.mean(d2 <= gamma) == pytest.approx(p, abs=5 * np.sqrt(p * (1 - p) / d2.size))


@pytest.mark.parametrize("bad", [0.0, 1.0, -0.1, 1.5, float("nan"), None, "0.9"])
def test_a_gate_probability_outside_0_1_is_refused(bad):
    with pytest.raises(ParameterError):
        gate_threshold(bad)


def test_the_innovation_distance_is_the_mahalanobis_distance():
    rng = np.random.default_rng(1)
    P, R = _spd(rng, 3), _spd(rng, 2)
    H, nu = rng.normal(size=(2, 3)), rng.normal(size=2)
    S, d2 = innovation_distance(P, H, R, nu)
    np.testing.assert_allclose(S, H @ P @ H.T + R, rtol=1e-14)
    assert d2 == pytest.approx(float(nu @ np.linalg.inv(H @ P @ H.T + R) @ nu), rel=1e-12)


def test_the_joseph_update_is_the_kalman_update_at_the_optimal_gain():
    """At K = P H^T S^-1 the Joseph form equals (I - K H) P, and the mean is m + K nu."""
    rng = np.random.default_rng(2)
    P, R = _spd(rng, 3), _spd(rng, 2)
    H, m, nu = rng.normal(size=(2, 3)), rng.normal(size=3), rng.normal(size=2)
    S = H @ P @ H.T + R
    m_new, P_new, K = joseph_update(m, P, H, R, S, nu)
    K_ref = P @ H.T @ np.linalg.inv(S)
    np.testing.assert_allclose(K, K_ref, rtol=1e-12)
    np.testing.assert_allclose(m_new, m + K_ref @ nu, rtol=1e-12)
    np.testing.assert_allclose(P_new, (np.eye(3) - K_ref @ H) @ P, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(P_new, P_new.T, rtol=1e-13)  # symmetric, up to round-off
    assert np.all(np.linalg.eigvalsh(P_new) > 0)


def test_the_altimeter_innovation_and_its_density():
    altitude = np.array([1500.0, 1460.0, 1530.0])
    ground = np.array([250.0, np.nan, 180.0])
    nu, off = altimeter_innovation(1225.0, altitude, ground)
    np.testing.assert_array_equal(off, [False, True, False])
    np.testing.assert_array_equal(nu, [1225.0 - (1500.0 - 250.0), 0.0, 1225.0 - (1530.0 - 180.0)])
    s = np.array([400.0, 500.0, 900.0])
    log_p = innovation_log_density(nu, s, off)
    assert log_p[1] == -np.inf
    np.testing.assert_allclose(log_p[[0, 2]], stats.norm.logpdf(nu[[0, 2]], 0.0, np.sqrt(s[[0, 2]])), rtol=1e-13)


def test_both_terrain_models_move_position_and_heading_alike_and_predict_their_own_states():
    """The marginalised and the map-bias model share one horizontal move: on one generator they move
    (x, y, psi) identically, by V dt (cos psi, sin psi) on average, and each predicts its Kalman columns."""
    from pfcourse.scenarios.terrain.map import TerrainMap
    from pfcourse.scenarios.terrain.map_bias import MapBiasTerrainModel
    from pfcourse.scenarios.terrain.marginalised import MarginalisedTerrainModel
    from pfcourse.scenarios.terrain.scenario import AircraftScenario

    terrain = TerrainMap(np.full((60, 60), 250.0), dx=1000.0, dy=1000.0)
    scenario = AircraftScenario(duration=20.0, x0=np.array([30000.0, 30000.0, 1500.0, 0.3]),
                                P0=np.diag([300.0, 300.0, 100.0, 0.1]) ** 2)
    plain, biased = MarginalisedTerrainModel(terrain, scenario), MapBiasTerrainModel(terrain, scenario, 12.0, 300.0)
    rows = plain.sample_initial(50_000, np.random.default_rng(3))
    rows_b = np.column_stack([rows[:, :4], np.full(len(rows), 2.0), rows[:, 4], np.full(len(rows), -5.0),
                              np.full(len(rows), 100.0)])
    moved = plain.sample_transition(rows, 1, np.random.default_rng(4))
    moved_b = biased.sample_transition(rows_b, 1, np.random.default_rng(4))
    np.testing.assert_array_equal(moved[:, [0, 1, 3]], moved_b[:, [0, 1, 3]])
    step = moved[:, :2] - rows[:, :2] - scenario.speed * scenario.dt * np.column_stack([np.cos(rows[:, 3]),
                                                                                        np.sin(rows[:, 3])])
    noise_sd = np.sqrt(np.diag(scenario.Qf)[:2] * scenario.dt)
    # the noise of the move has mean 0: six standard errors of the mean of 50 000 draws
    assert np.all(np.abs(step.mean(axis=0)) < 6 * noise_sd / np.sqrt(len(rows)))
    np.testing.assert_array_equal(moved[:, 2], rows[:, 2])  # the altitude's mean: a random walk keeps it
    np.testing.assert_allclose(moved[:, 4], rows[:, 4] + scenario.Qf[2, 2] * scenario.dt, rtol=1e-15)
    # the map bias: b_k = a b_(k-1) + w_b, a = exp(-V dt / L), Var w_b = sigma_b^2 (1 - a^2)
    a, q = np.exp(-scenario.speed * scenario.dt / 300.0), scenario.Qf[2, 2] * scenario.dt
    predicted = np.column_stack([a * rows_b[:, 4], rows_b[:, 5] + q, a * rows_b[:, 6],
                                 a * a * rows_b[:, 7] + 12.0**2 * (1 - a * a)])
    np.testing.assert_allclose(moved_b[:, 4:], predicted, rtol=1e-12)
