"""The bound under the filter's own model: flights drawn from that model, and the weighted PCRB recursion
(its bootstrap and per-flight forms) against the plain one."""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.errors import ShapeError
from pfcourse.studies.terrain_remedies import model_flight
from pfcourse.seeding import data_rng
from pfcourse.scenarios.terrain.map import load_jacksboro
from pfcourse.scenarios.terrain.pcrb import pcrb_recursion, weighted_pcrb_recursion
from pfcourse.scenarios.terrain.scenario import AircraftScenario, dynamics_jacobian, measurement_jacobian, propagate


@pytest.fixture(scope="module")
def world():
    return AircraftScenario(), load_jacksboro()


def test_model_flights_wander_as_the_filters_process_noise_says(world):
    scenario, terrain = world
    flights = [model_flight(scenario, terrain, data_rng(1, r))[0] for r in range(40)]
    steps = np.concatenate([f.truth[1:] - propagate(f.truth[:-1], scenario.speed, scenario.omega, scenario.dt)
                            for f in flights])
    steps[:, 3] = np.angle(np.exp(1j * steps[:, 3]))
    # 40 x 80 increments: each variance within 15 % of Qf dt (chi-square with 3160 dof: sd about 2.5 %)
    assert np.allclose(steps.var(axis=0), np.diag(scenario.Qf) * scenario.dt, rtol=0.15)
    f = flights[0]
    measured = scenario.measured()
    residual = (f.truth[:, 2] - f.terrain_height - f.measurements[:, 0])[measured]
    assert abs(residual.std() / np.sqrt(scenario.Rf) - 1) < 0.35  # one flight's ~75 readings
    assert np.isnan(f.measurements[~measured, 0]).all()


def test_model_flights_are_drawn_from_the_generator_given(world):
    scenario, terrain = world
    a, _ = model_flight(scenario, terrain, data_rng(1, 3))
    b, _ = model_flight(scenario, terrain, data_rng(1, 3))
    c, _ = model_flight(scenario, terrain, data_rng(1, 4))
    state = np.random.get_state()[1].copy()
    assert np.array_equal(a.truth, b.truth) and not np.allclose(a.truth, c.truth)
    assert np.array_equal(np.random.get_state()[1], state)


@pytest.fixture(scope="module")
def terms(world):
    scenario, terrain = world
    X = np.array([model_flight(scenario, terrain, data_rng(1, r))[0].truth for r in range(6)])
    F = np.array([[dynamics_jacobian(x, scenario.speed, scenario.dt) for x in t] for t in X])
    H = np.array([[measurement_jacobian(x, terrain) for x in t] for t in X])
    return np.linalg.inv(scenario.P0), F, scenario.Qf * scenario.dt, H, np.array([[scenario.Rf]]), scenario.measured()


def test_weighted_recursion_is_the_plain_one_on_any_weighting(terms):
    plain = pcrb_recursion(*terms)
    J0, F, Q, H, R, measured = terms
    out = weighted_pcrb_recursion(*terms, np.array([np.ones(6), 3 * np.ones(6), [2, 0, 1, 0, 0, 3], np.eye(6)[4]]))
    assert np.allclose(out[0], plain, rtol=1e-10) and np.allclose(out[1], plain, rtol=1e-10)
    # a resample's counts are the plain recursion on the flights repeated
    rows = [0, 0, 2, 5, 5, 5]
    assert np.allclose(out[2], pcrb_recursion(J0, F[rows], Q, H[rows], R, measured), rtol=1e-10)
    # one flight alone is that flight's own bound
    assert np.allclose(out[3], pcrb_recursion(J0, F[4:5], Q, H[4:5], R, measured), rtol=1e-10)


def test_strict_bound_is_below_the_rms_of_per_flight_bounds(terms):
    strict = weighted_pcrb_recursion(*terms, np.ones((1, 6)))[0, -1]
    per = weighted_pcrb_recursion(*terms, np.eye(6))[:, -1]
    # the inverse is convex on positive definite matrices: inv(mean J) <= mean inv(J)
    assert np.all(np.linalg.eigvalsh(per.mean(axis=0) - strict) > -1e-9 * np.abs(strict).max())


def test_weighted_recursion_refuses_bad_weights(terms):
    with pytest.raises(ShapeError):
        weighted_pcrb_recursion(*terms, np.ones((2, 5)))
    with pytest.raises(ShapeError):
        weighted_pcrb_recursion(*terms, -np.ones((1, 6)))
