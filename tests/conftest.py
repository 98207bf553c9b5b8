"""Shared fixtures of the unit tests."""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.kalman import kalman_filter
from pfcourse.scenarios.landmarks.scenario import quadrant_scenario, simulate


@pytest.fixture(scope="session")
def noisy_landmarks():
    """Scenario A (2 landmarks) with process noise on every component and Rv = 0.5^2 I.

    Every component moving and a moderately informative measurement put the
    particle filter in its asymptotic 1/sqrt(N) regime already at N ~ 250, so the
    convergence tests stay fast.  Returns (model, simulation, Kalman result).
    """
    scenario = quadrant_scenario().with_(
        Qw=0.05**2 * np.eye(6), Rv=0.5**2 * np.eye(4), n_samples=15
    )
    sim = simulate(scenario, 7)
    model = scenario.model()
    return model, sim, kalman_filter(model, sim.measurements)
