"""``LastCloud`` keeps the last step's cloud only; ``flight_figure`` draws one cloud (issue 44, review pkg44 S11).

The terrain chapters' panels drew the last cloud of a run that kept every cloud (``Clouds()``: K x N x d
floats for one N x d picture). They now collect ``LastCloud()``: the same cloud, float for float, and the
same run (collectors only read the steps).
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from pfcourse import ParticleFilter  # noqa: E402
from pfcourse.book.figures.terrain import flight_figure  # noqa: E402
from pfcourse.collectors import Clouds, LastCloud  # noqa: E402
from pfcourse.scenarios.terrain.map import load_jacksboro  # noqa: E402
from pfcourse.scenarios.terrain.scenario import AircraftScenario, simulate  # noqa: E402
from pfcourse.seeding import data_rng, filter_rng  # noqa: E402


@pytest.fixture(scope="module")
def flight_runs():
    terrain, scenario = load_jacksboro(), AircraftScenario()
    flight = simulate(scenario, terrain, data_rng(0, 3))
    z = flight.measurements[:40]
    pf = ParticleFilter(scenario.model(terrain), 500, threshold=0.5, resampler="multinomial")
    every = pf.run(z, rng=filter_rng(0, 3), collect=[Clouds()])
    last = pf.run(z, rng=filter_rng(0, 3), collect=[LastCloud()])
    return terrain, flight, every, last


def test_the_last_cloud_is_the_last_of_every_cloud(flight_runs):
    _, _, every, last = flight_runs
    step = last.collected["last_cloud"]
    assert step.k == len(every.weights) - 1
    assert np.array_equal(step.particles, every.particles[-1])
    assert np.array_equal(step.weights, every.weights[-1])
    assert np.array_equal(last.mean, every.mean) and np.array_equal(last.cov, every.cov)


def test_a_collector_object_serves_two_runs():
    pf = ParticleFilter(AircraftScenario().model(load_jacksboro()), 50)
    z = simulate(AircraftScenario(), load_jacksboro(), data_rng(0, 1)).measurements
    keep = LastCloud()
    short = pf.run(z[:3], rng=1, collect=[keep]).collected["last_cloud"]
    longer = pf.run(z[:7], rng=1, collect=[keep]).collected["last_cloud"]
    assert (short.k, longer.k) == (2, 6)


def test_flight_figure_draws_the_cloud_it_is_given(flight_runs):
    terrain, flight, every, last = flight_runs
    k = len(every.weights) - 1
    # the figure's time axis is the flight's; cut the flight to the steps run
    short = type("Short", (), {"T": flight.T[: k + 1], "truth": flight.truth[: k + 1]})()
    fig = flight_figure(terrain, short, last.mean, last.collected["last_cloud"], "test")
    cloud_line = next(line for line in fig.axes[0].lines if line.get_label().startswith("particles"))
    idx = np.random.default_rng(0).choice(500, 500, p=every.weights[-1])
    assert np.array_equal(cloud_line.get_xdata(), every.particles[-1, idx, 0] / 1000.0)
    assert cloud_line.get_label() == f"particles at t = {flight.T[k]:.0f} s"
    plt.close(fig)
