"""The Kalman-family runs whose outputs tests/data/kalman_reference.npz stores.

The four entry points (``kalman_filter``, ``run_ekf``/``run_ukf``, the terrain
``extended_kalman_filter``/``unscented_kalman_filter``) were run on these cases before they became
wrappers over the one loop of :mod:`pfcourse.kalman` (commit 86d320c, ``python3
tests/kalman_cases.py`` writes the file); tests/test_kalman.py checks that they still give
the same floats.
"""

from __future__ import annotations

from pathlib import Path

import pfcourse  # noqa: F401  (before NumPy: the pinned arithmetic)
import numpy as np

from pfcourse.kalman import kalman_filter
from pfcourse.scenarios.landmarks.scenario import quadrant_scenario, simulate as simulate_landmarks
from pfcourse.linear_gaussian import LinearGaussianModel
from pfcourse.scenarios.robot.kalman import run_ekf, run_ukf
from pfcourse.scenarios.robot.scenario import RobotModel, simulate_robot
from pfcourse.scenarios.terrain.kalman import unscented_kalman_filter
from pfcourse.scenarios.terrain.map import load_jacksboro
from pfcourse.scenarios.terrain.scenario import AircraftScenario, extended_kalman_filter, simulate as simulate_flight

REFERENCE = Path(__file__).parent / "data" / "kalman_reference.npz"
FIELDS = ("mean", "cov", "innovation", "innovation_cov", "predicted", "gain", "log_likelihood_increments")
TIGHT = dict(P0=np.diag([30.0, 30.0, 5.0, 0.01]) ** 2, Qf=np.diag([1.0, 1.0, 0.1, 0.001]) ** 2)


def cases():
    """``{name: callable}``: each call runs one filter on one seeded case and returns its result."""
    out = {}
    # Scenario A, every component moving, and with a third of the readings' components missing.
    scenario = quadrant_scenario().with_(Qw=0.05**2 * np.eye(6), Rv=0.5**2 * np.eye(4), n_samples=15)
    sim = simulate_landmarks(scenario, 7)
    out["kf_landmarks"] = lambda: kalman_filter(scenario.model(), sim.measurements)
    holes = simulate_landmarks(quadrant_scenario(), 2).measurements.copy()
    holes[np.random.default_rng(1).random(holes.shape) < 0.3] = np.nan
    out["kf_landmarks_holes"] = lambda: kalman_filter(quadrant_scenario().model(), holes)
    scalar = LinearGaussianModel(F=[[0.9]], H=[[1.0]], m0=[0.0], P0=[[1.0]], Q=[[0.09]], R=[[0.25]])
    z = np.random.default_rng(5).normal(size=(30, 1))
    z[[3, 4, 17]] = np.nan
    out["kf_scalar"] = lambda: kalman_filter(scalar, z)
    # The robot: a default run, and one facing -x (the heading straddles the cut at pi).
    for label, sim_r in (("default", simulate_robot(rng=0, n_steps=200)),
                         ("across_pi", simulate_robot(rng=2, n_steps=150, start=(1.0, -50.0, np.pi))),
                         ("sparse", simulate_robot(rng=4, n_steps=200, dt_meas=5.0, gap=(80.0, 120.0)))):
        model = RobotModel.for_simulation(sim_r)
        out[f"robot_ekf_{label}"] = lambda m=model, s=sim_r: run_ekf(m, s.measurements)
        out[f"robot_ukf_{label}"] = lambda m=model, s=sim_r: run_ukf(m, s.measurements)
    sim_r = simulate_robot(rng=3, n_steps=100)
    model = RobotModel.for_simulation(sim_r, q_scale=1.0, r_scale=1.0)
    out["robot_ekf_cov"] = lambda: run_ekf(model, sim_r.measurements, np.diag([4.0, 4.0, 0.1]))
    out["robot_ukf_settings"] = lambda: run_ukf(model, sim_r.measurements, np.diag([4.0, 4.0, 0.1]),
                                                alpha=0.5, beta=2.0, kappa=1.0)
    # Terrain: tracking flights, a flight west across the cut, the report's prior (lost or not), dead reckoning off the map.
    terrain = load_jacksboro()
    tight = AircraftScenario().with_(**TIGHT)
    west = AircraftScenario().with_(**TIGHT, x0=np.array([21000.0, 15000.0, 1500.0, np.pi - 0.005]))
    flights = {"tight": (tight, simulate_flight(tight, terrain, 3).measurements),
               "west": (west, simulate_flight(west, terrain, 0, initial_state=west.x0).measurements),
               "gap": (AircraftScenario().with_(**TIGHT, gap=(20.0, 40.0), measurement_period=2.0), None),
               "off_map": (AircraftScenario().with_(**TIGHT, x0=np.array([500.0, 15000.0, 1500.0, np.pi])),
                           np.full(81, np.nan))}
    flights["gap"] = (flights["gap"][0], simulate_flight(flights["gap"][0], terrain, 5).measurements)
    edge = AircraftScenario().with_(x0=np.array([2500.0, 15000.0, 1500.0, np.pi]))
    flights["edge"] = (edge, simulate_flight(edge, terrain, 0, initial_state=np.array([9000.0, 15000.0, 1500.0, np.pi]))
                       .measurements)
    for seed in range(3):
        flights[f"report_{seed}"] = (AircraftScenario(), simulate_flight(AircraftScenario(), terrain, seed).measurements)
    for label, (sc, zs) in flights.items():
        out[f"terrain_ekf_{label}"] = lambda sc=sc, zs=zs: extended_kalman_filter(sc, terrain, zs)
        out[f"terrain_ukf_{label}"] = lambda sc=sc, zs=zs: unscented_kalman_filter(sc, terrain, zs)
    return out


def arrays(name: str, result) -> dict:
    """The result's fields as ``{name/field: array}`` (``lost_at`` as -1 when the run was not lost)."""
    found = {f"{name}/{f}": getattr(result, f) for f in FIELDS}
    found[f"{name}/lost_at"] = np.array(-1 if result.lost_at is None else result.lost_at)
    return found


if __name__ == "__main__":
    stored = {}
    for name, run in cases().items():
        stored.update(arrays(name, run()))
    np.savez_compressed(REFERENCE, **stored)
    print({k: int(v) for k, v in stored.items() if k.endswith("lost_at")})
