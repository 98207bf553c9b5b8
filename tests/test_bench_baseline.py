"""The benchmark's loop-style baseline filters the same posterior as pfcourse's ParticleFilter.

Speed ratios are only meaningful between filters that compute the same thing: on the
benchmark's robot data, the loop filter's weighted mean must stay within Monte Carlo error
of pfcourse's.  With N = 2000 particles and resampling whenever ESS < N/2, each estimate's
Monte Carlo standard deviation is at most about ``sd * sqrt(2 / (N/2))`` = 0.045 sd
(``sd`` the posterior standard deviation), so the difference of two independent filters has
sd below 0.07 sd; its average over the run is checked against 0.5 sd (7 sigma).
"""

import sys
from pathlib import Path

import numpy as np

from pfcourse.filter import ParticleFilter
from pfcourse.metrics import position_error, position_spread
from pfcourse.scenarios.robot.scenario import RobotModel, simulate_robot

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
from loop_filters import robot_loop_filter  # noqa: E402


def test_loop_baseline_agrees_with_pfcourse_on_the_robot():
    sim = simulate_robot(rng=0, n_steps=60)
    model = RobotModel.for_simulation(sim)
    data = {
        "landmarks": sim.landmarks, "odometry": sim.odometry, "measurements": sim.measurements,
        "q_est": model.q_est, "r_est": model.r_est, "start": model.start,
        "initial_std": model.initial_std, "dt": model.dt,
    }
    n = 2000
    reference = ParticleFilter(model, n, threshold=0.5).run(sim.measurements, 1)
    loop = robot_loop_filter(data, n, 2)
    sd = position_spread(reference.cov)
    diff = position_error(reference.mean, loop)
    assert np.mean(diff / sd) < 0.5
