"""The cloud animation draws one frame per requested step and refuses runs without stored particles."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import pytest

from pfcourse.figures.clouds import animate_clouds
from pfcourse.errors import ParameterError
from pfcourse.filter import ParticleFilter
from pfcourse.landmarks.kalman import kalman_filter
from pfcourse.landmarks.scenario import quadrant_scenario, simulate


def test_frames_and_artists():
    scenario = quadrant_scenario()
    sim = simulate(scenario, rng=0)
    model = scenario.model()
    res = ParticleFilter(model, 20, threshold=0.5).run(sim.Z, rng=1, store_particles=True)
    anim = animate_clouds({"SIR": res}, kalman_filter(model, sim.Z), sim.X, frames=range(3))
    html = anim.to_jshtml()
    # One embedded PNG per requested step.
    assert html.count("data:image/png") == 3

def test_missing_particles_raise_a_named_error():
    scenario = quadrant_scenario()
    sim = simulate(scenario, rng=0)
    model = scenario.model()
    res = ParticleFilter(model, 20).run(sim.Z, rng=1)
    with pytest.raises(ParameterError):
        animate_clouds({"SIR": res}, kalman_filter(model, sim.Z), sim.X, frames=range(3))
