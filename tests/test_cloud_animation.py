"""The cloud animation draws one frame per requested step and refuses runs without stored particles."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import pytest

from pfcourse.book.figures.clouds import animate_clouds
from pfcourse.errors import ParameterError
from pfcourse.collectors import Clouds
from pfcourse.filter import ParticleFilter
from pfcourse.kalman import kalman_filter
from pfcourse.scenarios.landmarks.scenario import quadrant_scenario, simulate


def test_frames_and_artists():
    scenario = quadrant_scenario()
    sim = simulate(scenario, rng=0)
    model = scenario.model()
    res = ParticleFilter(model, 20, threshold=0.5).run(sim.measurements, rng=1, collect=[Clouds()])
    anim = animate_clouds({"SIR": res}, kalman_filter(model, sim.measurements), sim.truth, frames=range(3))
    html = anim.to_jshtml()
    # One embedded PNG per requested step.
    assert html.count("data:image/png") == 3

def test_missing_particles_raise_a_named_error():
    scenario = quadrant_scenario()
    sim = simulate(scenario, rng=0)
    model = scenario.model()
    res = ParticleFilter(model, 20).run(sim.measurements, rng=1)
    with pytest.raises(ParameterError):
        animate_clouds({"SIR": res}, kalman_filter(model, sim.measurements), sim.truth, frames=range(3))


def test_one_function_serves_the_robot_and_the_terrain_views():
    """The robot view (window following the truth, hooks for the landmarks and the observed one)
    and the terrain view (km, particles drawn by weight, paths) are options of the same function."""
    from pfcourse.book.figures.clouds import animate_clouds as animate
    from pfcourse.scenarios.robot import RobotModel, simulate_robot
    from pfcourse.book.figures.robot import landmarks_background, sight_overlay

    sim = simulate_robot(None, 1, n_steps=12)
    res = ParticleFilter(RobotModel.for_simulation(sim), 100).run(sim.measurements, 1, collect=[Clouds()])
    robot = animate(
        {"PF": res}, None, sim.truth, [0, 5, 11], None, follow=2.0, ellipses=False, trail=True,
        background=landmarks_background(sim), overlay=sight_overlay(sim), legend=True,
    )
    assert robot.to_jshtml().count("data:image/png") == 3
    terrain_like = animate({"PF": res}, None, sim.truth, [0, 11], None, blocks=[(0, 1)], ellipses=False,
                           scale=1e-3, unit="km", max_points=30, by_weight=True)
    assert terrain_like.to_jshtml().count("data:image/png") == 2
