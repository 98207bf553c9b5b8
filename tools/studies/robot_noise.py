"""The robot's noise scales by maximum likelihood (Part V), stored under book/data/likelihood/.

    .venv/bin/python tools/studies/robot_noise.py

``robot_noise.csv``: on RUNS seeded robot runs (scenario C, N_STEPS steps, truth Q_est = Q_true,
R_est = R_true, i.e. scales 1), the maximum-likelihood scales (q, r) from the particle
likelihood (N_ML particles, common random numbers, bounded Nelder-Mead on log scales, start
at Part III's hand-tuned (2, 2)); then the position RMSE (after 20 s) and the mean NEES of a
filter with N_EVAL particles (a fresh seed) run with the ML scales, with the hand-tuned (2, 2)
and with the truth (1, 1).  ``robot_noise.json``: provenance.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

import pfcourse  # noqa: F401  (pins the arithmetic first)
from pfcourse import ParticleFilter
from pfcourse.diagnostics import nees
from pfcourse.experiments.likelihood import max_likelihood_scales, robot_log_likelihood
from pfcourse.robot import ANGLE_INDICES, RobotModel, RobotScenario, rmse, simulate_robot
from pfcourse.experiments.provenance import launch_commit, write_provenance
from pfcourse.experiments.study import run_study

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "book" / "data" / "likelihood"
# the commit the study is launched from (recorded in the provenance, whatever is committed meanwhile)
LAUNCH_COMMIT = launch_commit()
N_STEPS, RUNS, BASE_SEED = 200, 100, 6
N_ML, N_EVAL, START = 300, 1000, (2.0, 2.0)
ROBOT = RobotScenario().with_(n_steps=N_STEPS)


def robot_noise_run(seed: int, n_particles: int) -> dict:
    sim = simulate_robot(ROBOT, seed)
    scales, nfev = max_likelihood_scales(
        lambda t: robot_log_likelihood(sim, t[0], t[1], n_particles, seed + 1), np.array(START))
    out = {"q_ml": float(scales[0]), "r_ml": float(scales[1]), "nfev": nfev}
    for name, (q, r) in {"ml": scales, "hand": START, "truth": (1.0, 1.0)}.items():
        model = RobotModel.for_simulation(sim, q_scale=float(q), r_scale=float(r))
        res = ParticleFilter(model, N_EVAL).run(sim.measurements, seed + 2)
        out[f"rmse_{name}"] = rmse(sim.truth, res.mean, start=20)[0]
        out[f"nees_{name}"] = float(np.mean(nees(sim.truth[20:], res.mean[20:], res.cov[20:], ANGLE_INDICES)))
    return out


def main() -> None:
    start = time.perf_counter()
    table = run_study(robot_noise_run, {"n_particles": [N_ML]}, RUNS, base_seed=BASE_SEED, progress=False)
    OUT.mkdir(parents=True, exist_ok=True)
    table.drop(columns=["seconds"]).to_csv(OUT / "robot_noise.csv", index=False)
    write_provenance(
        OUT / "robot_noise.json", code="tools/studies/robot_noise.py", commit=LAUNCH_COMMIT,
        seconds=time.perf_counter() - start, file="robot_noise.csv",
        scenario=f"RobotScenario().with_(n_steps={N_STEPS}), truth scales (1, 1)",
        n_runs=RUNS, base_seed=BASE_SEED, n_particles_ml=N_ML, n_particles_eval=N_EVAL,
        start=START, bounds=[0.1, 10.0],
        seeds="simulation: replicate_seed(base_seed, run); likelihood filter: +1; evaluation filter: +2")


if __name__ == "__main__":
    main()
