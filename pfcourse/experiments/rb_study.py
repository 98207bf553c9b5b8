"""The Rao-Blackwellisation study: six filters of scenario A against the exact Kalman posterior.

One *row* is one filter run on one simulation: method, particle count ``N``, seed.  The
simulation uses seed ``s``, the filter ``s + 10**6`` (common random numbers: every method
and every ``N`` sees the same simulations and starts from the same filter seed).  Scores:

* ``landmark_error``, ``robot_error``: RMS over the landmark (robot) coordinates of the
  filter mean minus the Kalman mean at the last step (m);
* ``loglik_error``: the filter's ``log p^(z_{0:K-1})`` minus the Kalman filter's;
* ``ess``: mean ESS / N over the steps with a measurement (the first-stage weights for the
  auxiliary filters, whose engine weights are uniform);
* ``nees_k``: ``(x_k - mu_k)^T Sigma_k^{-1} (x_k - mu_k)`` against the true state, per step
  (``+inf`` when the cloud's covariance is singular);
* ``seconds_per_step``: wall time of the run over ``K`` (volatile: not re-computed by tests).

Row ``method="kalman"`` (``N = 0``) holds the Kalman filter's own NEES.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from pfcourse.diagnostics import nees
from pfcourse.filter import ParticleFilter
from pfcourse.kalman import kalman_filter
from pfcourse.proposals import FullyAdaptedAuxiliary, LinearGaussianOptimal, OptimalProposal
from pfcourse.landmarks.rao_blackwell import RaoBlackwellModel, RaoBlackwellProposal
from pfcourse.landmarks.scenario import LandmarkScenario, circle_scenario, quadrant_scenario, simulate

#: Methods, in the order of the chapter: label, and whether the map is integrated out.
METHODS: dict[str, str] = {
    "sir": "SIR, bootstrap",
    "sir_optimal": "SIR, optimal proposal",
    "apf": "auxiliary PF (fully adapted)",
    "rbpf_prior": "RBPF, prior proposal (FastSLAM 1.0)",
    "rbpf_optimal": "RBPF, optimal proposal (FastSLAM 2.0)",
    "rb_apf": "RBPF, auxiliary (fully adapted)",
}
SCENARIOS = {"quadrant": quadrant_scenario, "circle": circle_scenario}
THRESHOLD = 1 / 3  # the lab's resampling threshold, as in the SIR chapter


def make_filter(method: str, scenario: LandmarkScenario, n_particles: int):
    """``(run(Z, seed) -> FilterResult of the state, first_stage_ess_list or None)`` for a method."""
    model = scenario.model()
    if method in ("sir", "sir_optimal"):
        prop = OptimalProposal() if method == "sir_optimal" else None
        pf = ParticleFilter(model, n_particles, threshold=THRESHOLD, proposal=prop)
        return (lambda Z, s: pf.run(Z, s)), None
    if method == "apf":
        prop = FullyAdaptedAuxiliary(LinearGaussianOptimal())
        pf = ParticleFilter(model, n_particles, threshold=1.0, proposal=prop)
        return (lambda Z, s: pf.run(Z, s)), prop.first_stage_ess
    rb = RaoBlackwellModel(model)
    if method in ("rbpf_prior", "rbpf_optimal"):
        prop = RaoBlackwellProposal(optimal=method == "rbpf_optimal")
        pf = ParticleFilter(rb, n_particles, threshold=THRESHOLD, proposal=prop)
        return (lambda Z, s: rb.marginal(pf.run(Z, s))), None
    if method == "rb_apf":
        prop = FullyAdaptedAuxiliary(RaoBlackwellProposal(optimal=True))
        pf = ParticleFilter(rb, n_particles, threshold=1.0, proposal=prop)
        return (lambda Z, s: rb.marginal(pf.run(Z, s))), prop.first_stage_ess
    raise ValueError(f"unknown method {method!r}; choose one of {sorted(METHODS)}")


def run_rows(
    scenario_name: str, seed: int, methods: Sequence[str], n_values: Sequence[int]
) -> list[dict]:
    """Every row of one simulation (seed ``seed``): the Kalman row, then each method and ``N``."""
    scenario = SCENARIOS[scenario_name]()
    sim = simulate(scenario, rng=seed)
    kf = kalman_filter(scenario.model(), sim.measurements)
    measured = sim.seen.any(axis=1)
    nr = 2
    rows = [
        dict(scenario=scenario_name, method="kalman", N=0, seed=seed, landmark_error=0.0,
             robot_error=0.0, loglik_error=0.0, ess=1.0, seconds_per_step=0.0,
             **{f"nees_{k:02d}": v for k, v in enumerate(nees(sim.truth, kf.mean, kf.cov))})
    ]
    for method in methods:
        for n in n_values:
            run, first_stage = make_filter(method, scenario, n)
            start = time.perf_counter()
            res = run(sim.measurements, seed + 10**6)
            seconds = (time.perf_counter() - start) / len(sim.measurements)
            err = res.mean[-1] - kf.mean[-1]
            ess = np.array(first_stage) if first_stage is not None else res.ess[measured]
            rows.append(dict(
                scenario=scenario_name, method=method, N=n, seed=seed,
                landmark_error=float(np.sqrt(np.mean(err[nr:] ** 2))),
                robot_error=float(np.sqrt(np.mean(err[:nr] ** 2))),
                loglik_error=res.log_likelihood - kf.log_likelihood,
                ess=float(np.mean(ess) / n),
                seconds_per_step=seconds,
                **{f"nees_{k:02d}": v for k, v in enumerate(nees(sim.truth, res.mean, res.cov))},
            ))
    return rows
