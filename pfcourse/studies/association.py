"""One seeded run of the robot with anonymous readings, through the particle filter and the
nearest-neighbour EKF on the same data (the unit of the data-association study).

The scenario (:data:`SCENARIO`): the lab's robot and map of five landmarks, driving forward at
0.5 m/s for 300 s with no reading for 100 s in the middle, so that the filters come out of the
gap uncertain enough for identical landmarks to be confused.  The sensor
(:class:`~pfcourse.scenarios.robot.association.ClutterSensor`) detects with ``P_D`` = :data:`P_DETECT`, adds
Poisson clutter of rate ``lambda`` per measurement step, over a range of :data:`MAX_RANGE` m.

Seeds (:mod:`pfcourse.seeding`): run ``r`` simulates its robot and readings from
``data_rng(0, r)`` (two spawned streams: the robot, then the readings), and its particle filter
runs on ``filter_rng(0, r)``; the EKF is deterministic.  The robot and its detections are the same
for every clutter rate (common random numbers).

Metrics: ``pf_rmse_m`` and ``ekf_rmse_m`` (the *sequential* nearest-neighbour EKF, every gated
reading in turn), ``sqrt(mean_k |p^_k - p_k|^2)`` over every step (m);
``ekf_wrong``, the readings the EKF gave to a wrong landmark (or a clutter reading to a landmark);
``clutter``, the clutter readings of the run.  :func:`pdaf_row` runs the PDA filter on the same
readings (the study ``data_association_pdaf``), :func:`nn_row` the nearest-neighbour standard
filter, one update a step (the study ``data_association_nn``).
"""

from __future__ import annotations

import time

import numpy as np

from pfcourse.filter_config import FilterSettings
from pfcourse.metrics import position_error, rmse
from pfcourse.scenarios.robot.association import AssociationModel, ClutterSensor, run_nn_ekf, run_pdaf, simulate_readings
from pfcourse.scenarios.robot.scenario import RobotModel, RobotSimulation, simulate_robot
from pfcourse.seeding import data_rng, filter_rng

#: Scenario changes from the lab's robot: forward at 0.5 m/s for 300 s, no reading in [100, 200) s.
SCENARIO = {"n_steps": 300, "speed": (0.5, 0.0), "gap": (100.0, 200.0)}
P_DETECT = 0.9
MAX_RANGE = 200.0
N_PARTICLES = 500
#: The particle filter: bootstrap, N_PARTICLES, systematic resampling at ESS < N/2.
FILTER = FilterSettings(N_PARTICLES)
#: Clutter rates of the study (mean false readings per measurement step).
CLUTTER_RATES = (0.0, 1.0, 2.0, 4.0)
N_RUNS = 100


def simulate_run(seed: int, clutter_rate: float) -> tuple[RobotSimulation, ClutterSensor, object]:
    """Run ``seed``: the robot (:data:`SCENARIO`), its sensor and its anonymous readings."""
    world, noise = data_rng(0, seed).spawn(2)
    sim = simulate_robot(rng=world, **SCENARIO)
    sensor = ClutterSensor(P_DETECT, clutter_rate, MAX_RANGE)
    return sim, sensor, simulate_readings(sim, sensor, noise)


def position_rmse(truth, estimate) -> float:
    """``sqrt(mean_k |p^_k - p_k|^2)`` over every step (m)."""
    return float(rmse(position_error(truth, estimate)))


def row(seed: int, clutter_rate: float) -> dict:
    """The particle filter (:data:`N_PARTICLES`, bootstrap, systematic resampling at ESS < N/2) and the
    sequential nearest-neighbour EKF (``run_nn_ekf(..., rule="sequential")``) on run ``seed``: RMSEs, the EKF's wrong associations, run times."""
    sim, sensor, readings = simulate_run(seed, clutter_rate)
    model = AssociationModel(RobotModel.for_simulation(sim), sensor)
    t0 = time.perf_counter()
    pf = FILTER.build(model).run(readings.readings, rng=filter_rng(0, seed))
    t1 = time.perf_counter()
    ekf, chosen = run_nn_ekf(model, readings.readings, rule="sequential")
    t2 = time.perf_counter()
    return {"pf_rmse_m": position_rmse(sim.truth, pf.mean), "ekf_rmse_m": position_rmse(sim.truth, ekf.mean),
            "ekf_wrong": int(np.sum((chosen >= 0) & (chosen != readings.origin))),
            "clutter": int(readings.clutter_counts.sum()), "pf_seconds": t1 - t0, "ekf_seconds": t2 - t1}


def pdaf_row(seed: int, clutter_rate: float) -> dict:
    """The PDA filter (:func:`~pfcourse.scenarios.robot.association.run_pdaf`, gate as the nearest-neighbour EKF's)
    on run ``seed``, the same readings as :func:`row`'s: its RMSE, its mean NEES over the steps, its run time."""
    sim, sensor, readings = simulate_run(seed, clutter_rate)
    model = AssociationModel(RobotModel.for_simulation(sim), sensor)
    t0 = time.perf_counter()
    pdaf, _ = run_pdaf(model, readings.readings)
    t1 = time.perf_counter()
    from pfcourse.studies.comparison import _safe_nees
    from pfcourse.scenarios.robot.scenario import ANGLE_INDICES

    nees = _safe_nees(sim.truth, pdaf.mean, pdaf.cov, ANGLE_INDICES)
    return {"pdaf_rmse_m": position_rmse(sim.truth, pdaf.mean), "pdaf_nees_mean": float(np.mean(nees)),
            "pdaf_seconds": t1 - t0}


def nn_row(seed: int, clutter_rate: float) -> dict:
    """The nearest-neighbour standard filter (:func:`~pfcourse.scenarios.robot.association.run_nn_ekf`, ``rule="nearest"``:
    the single gated reading nearest the prediction, one update a step) on run ``seed``, the same readings as
    :func:`row`'s: its RMSE, its wrong associations and run time; and how many steps of the run the sequential
    variant of :func:`row` updated more than once (``sequential_multi_steps``)."""
    sim, sensor, readings = simulate_run(seed, clutter_rate)
    model = AssociationModel(RobotModel.for_simulation(sim), sensor)
    t0 = time.perf_counter()
    nn, chosen = run_nn_ekf(model, readings.readings, rule="nearest")
    t1 = time.perf_counter()
    _, sequential = run_nn_ekf(model, readings.readings, rule="sequential")
    return {"nn_rmse_m": position_rmse(sim.truth, nn.mean),
            "nn_wrong": int(np.sum((chosen >= 0) & (chosen != readings.origin))),
            "sequential_multi_steps": int(np.sum(np.sum(sequential >= 0, axis=1) > 1)),
            "nn_seconds": t1 - t0}
