"""Smoothing studies of Part V, stored under book/data/likelihood/.

    .venv/bin/python tools/studies/smoothing.py [landmarks] [robot]

* ``smoothing_landmarks.csv``: scenario A (noise on every component), N_A particles,
  N_A_RUNS seeded datasets: RMS distance of the FFBSm mean to the exact RTS mean and of the
  filter mean to the Kalman mean, in units of the exact standard deviations;
* ``smoothing_robot.csv``: the robot with a measurement gap, ROBOT_RUNS seeded runs, N_ROBOT
  particles: mean position error of the filter and of the FFBSm smoother inside the gap and
  outside it.

Each file has a ``.json`` beside it with its provenance.  ``tests/test_likelihood_data.py``
re-computes a seeded sample of the stored rows.
"""

from __future__ import annotations

import sys
import time
from functools import partial
from pathlib import Path

import numpy as np

import pfcourse  # noqa: F401  (pins the arithmetic first)
from pfcourse import ParticleFilter
from pfcourse import kalman_filter
from pfcourse.landmarks import quadrant_scenario, simulate
from pfcourse.robot import RobotModel, RobotScenario, simulate_robot
from pfcourse.robot.scenario import robot_transition_log_density
from pfcourse.smoothing import ffbsm, linear_gaussian_log_transition, pairwise, rts_smoother
from pfcourse.experiments.provenance import launch_commit, write_provenance
from pfcourse.experiments.study import run_study

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "book" / "data" / "likelihood"
# the commit the study is launched from (recorded in the provenance, whatever is committed meanwhile)
LAUNCH_COMMIT = launch_commit()

SCENARIO_A = quadrant_scenario().with_(Qw=0.05**2 * np.eye(6), Rv=0.5**2 * np.eye(4))
N_A, N_A_RUNS, A_SEED = [100, 400], 100, 4
ROBOT = RobotScenario().with_(n_steps=160, gap=(60.0, 110.0))
N_ROBOT, ROBOT_RUNS, ROBOT_SEED = 300, 100, 5


def landmarks_run(seed: int, n_particles: int) -> dict:
    sim = simulate(SCENARIO_A, seed)
    model = SCENARIO_A.model()
    kf = kalman_filter(model, sim.measurements)
    m_s, P_s = rts_smoother(model, kf)
    r = ParticleFilter(model, n_particles).run(sim.measurements, seed + 1, store_particles=True)
    s = ffbsm(r.particles, r.weights, linear_gaussian_log_transition(model))
    sd_s = np.sqrt(np.diagonal(P_s, axis1=1, axis2=2))
    sd_f = np.sqrt(np.diagonal(kf.cov, axis1=1, axis2=2))
    return {"smoother_vs_rts": float(np.sqrt(np.mean(((s.mean - m_s) / sd_s) ** 2))),
            "filter_vs_kalman": float(np.sqrt(np.mean(((r.mean - kf.mean) / sd_f) ** 2))),
            "rts_truth_error": float(np.sqrt(np.mean((m_s - sim.truth) ** 2))),
            "kalman_truth_error": float(np.sqrt(np.mean((kf.mean - sim.truth) ** 2))),
            "smoother_ess_median": float(np.median(1.0 / np.sum(s.weights**2, axis=1)))}


def robot_run(seed: int, n_particles: int) -> dict:
    sim = simulate_robot(ROBOT, seed)
    model = RobotModel.for_simulation(sim)
    r = ParticleFilter(model, n_particles).run(sim.measurements, seed + 1, store_particles=True)
    s = ffbsm(r.particles, r.weights, pairwise(partial(robot_transition_log_density, model)), model.angle_indices)
    t = np.arange(ROBOT.n_steps) * ROBOT.dt
    gap = (t >= ROBOT.gap[0]) & (t < ROBOT.gap[1])
    after = t >= 20  # outside the gap, after the first 20 s of convergence
    ef = np.linalg.norm(r.mean[:, :2] - sim.truth[:, :2], axis=1)
    es = np.linalg.norm(s.mean[:, :2] - sim.truth[:, :2], axis=1)
    return {"filter_gap_error": float(ef[gap].mean()), "smoother_gap_error": float(es[gap].mean()),
            "filter_outside_error": float(ef[after & ~gap].mean()),
            "smoother_outside_error": float(es[after & ~gap].mean()),
            "smoother_gap_ess_median": float(np.median(1.0 / np.sum(s.weights[gap] ** 2, axis=1)))}


def provenance(name: str, parameters: dict, seconds: float) -> None:
    write_provenance(OUT / f"{name}.json", code="tools/studies/smoothing.py", commit=LAUNCH_COMMIT, seconds=seconds,
                     file=f"{name}.csv", **parameters)


def main(parts: list[str]) -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    if "landmarks" in parts:
        start = time.perf_counter()
        table = run_study(landmarks_run, {"n_particles": N_A}, N_A_RUNS, base_seed=A_SEED, progress=False)
        table.drop(columns=["seconds"]).to_csv(OUT / "smoothing_landmarks.csv", index=False)
        provenance("smoothing_landmarks", {
            "scenario": "quadrant_scenario().with_(Qw=0.05**2 I6, Rv=0.5**2 I4), 50 samples",
            "n_particles": N_A, "n_runs": N_A_RUNS, "base_seed": A_SEED,
            "seeds": "dataset: replicate_seed(base_seed, run); filter: dataset seed + 1"},
            time.perf_counter() - start)
    if "robot" in parts:
        start = time.perf_counter()
        table = run_study(robot_run, {"n_particles": [N_ROBOT]}, ROBOT_RUNS, base_seed=ROBOT_SEED, progress=False)
        table.drop(columns=["seconds"]).to_csv(OUT / "smoothing_robot.csv", index=False)
        provenance("smoothing_robot", {
            "scenario": "RobotScenario().with_(n_steps=160, gap=(60.0, 110.0)); filter RobotModel.for_simulation "
                        "(q_scale = r_scale = 2), threshold 0.5, systematic",
            "n_particles": N_ROBOT, "n_runs": ROBOT_RUNS, "base_seed": ROBOT_SEED,
            "seeds": "simulation: replicate_seed(base_seed, run); filter: simulation seed + 1"},
            time.perf_counter() - start)


if __name__ == "__main__":
    main(sys.argv[1:] or ["landmarks", "robot"])
