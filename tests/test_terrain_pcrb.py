"""The PCRB recursion: exact (Kalman) in the linear-Gaussian case, and the terrain bound's properties."""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.seeding import data_rng
from pfcourse.scenarios.terrain.scenario import AircraftScenario, simulate
from pfcourse.errors import ShapeError
from pfcourse.scenarios.terrain.map import load_jacksboro
from pfcourse.scenarios.terrain.pcrb import horizontal_bound, pcrb_recursion, terrain_pcrb


def kalman_covariances(P0, F, Q, H, R, measured):
    P = P0.copy()
    out = []
    for k in range(len(measured)):
        if k:
            P = F @ P @ F.T + Q
        if measured[k]:
            S = H @ P @ H.T + R
            G = P @ H.T @ np.linalg.inv(S)
            P = (np.eye(len(P)) - G @ H) @ P
        out.append(P)
    return np.array(out)


def test_linear_gaussian_bound_is_the_kalman_covariance():
    rng = np.random.default_rng(0)
    d, K = 4, 30
    F = np.eye(d) + 0.1 * rng.standard_normal((d, d))
    A = rng.standard_normal((d, d))
    Q = A @ A.T / d + 0.1 * np.eye(d)
    H = rng.standard_normal((2, d))
    R = np.diag([0.5, 2.0])
    P0 = np.diag([10.0, 5.0, 1.0, 3.0])
    measured = rng.random(K) < 0.7
    bound = pcrb_recursion(np.linalg.inv(P0), np.broadcast_to(F, (1, K, d, d)), Q,
                           np.broadcast_to(H, (1, K, 2, d)), R, measured)
    np.testing.assert_allclose(bound, kalman_covariances(P0, F, Q, H, R, measured), rtol=1e-9, atol=1e-10)


def test_averaging_two_identical_trajectories_changes_nothing_and_shapes_are_checked():
    sc = AircraftScenario()
    terrain = load_jacksboro()
    X = simulate(sc, terrain, data_rng(0, 0)).truth
    one = terrain_pcrb(sc, terrain, X)
    two = terrain_pcrb(sc, terrain, np.stack([X, X]))
    np.testing.assert_allclose(one, two, rtol=1e-12)
    with pytest.raises(ShapeError):
        pcrb_recursion(np.eye(4), np.zeros((3, 4, 4)), np.eye(4), np.zeros((1, 3, 1, 4)), np.eye(1), np.ones(3, bool))


def test_terrain_bound_starts_at_the_prior_and_readings_shrink_it():
    sc = AircraftScenario()
    terrain = load_jacksboro()
    X = simulate(sc, terrain, data_rng(0, 1)).truth
    b = terrain_pcrb(sc, terrain, X)
    np.testing.assert_allclose(b[0], sc.P0)  # no reading at t = 0
    blind = terrain_pcrb(sc.with_(gap=(0.5, 80.0)), terrain, X)  # no reading at all
    assert np.all(horizontal_bound(b)[1:] < horizontal_bound(blind)[1:])
    assert horizontal_bound(b)[-1] < 0.1 * horizontal_bound(b)[0]


def test_noise_free_bound_is_the_kalman_covariance_with_q_zero_and_below_the_noisy_one():
    from pfcourse.scenarios.terrain.pcrb import deterministic_bound, terrain_bound_noise_free

    rng = np.random.default_rng(2)
    d, K = 3, 25
    F = np.eye(d) + 0.2 * rng.standard_normal((d, d))
    H = rng.standard_normal((1, d))
    R = np.array([[0.3]])
    P0 = np.diag([4.0, 2.0, 1.0])
    measured = np.ones(K, bool)
    measured[0] = False
    bound = deterministic_bound(np.linalg.inv(P0), np.broadcast_to(F, (K, d, d)), np.broadcast_to(H, (K, 1, d)), R, measured)
    np.testing.assert_allclose(bound, kalman_covariances(P0, F, np.zeros((d, d)), H, R, measured), rtol=1e-8, atol=1e-12)
    sc = AircraftScenario()
    terrain = load_jacksboro()
    X = simulate(sc, terrain, data_rng(0, 3)).truth
    assert np.all(horizontal_bound(terrain_bound_noise_free(sc, terrain, X))[1:]
                  <= horizontal_bound(terrain_pcrb(sc, terrain, X))[1:] * (1 + 1e-9))
