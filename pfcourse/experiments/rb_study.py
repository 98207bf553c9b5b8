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

Row ``method="kalman"`` (``N = 0``) holds the Kalman filter's own NEES.  The stored table lists,
for each scenario and seed, the Kalman row and then every method and ``N``.
"""

from __future__ import annotations

import time
import numpy as np

from pfcourse.diagnostics import nees
from pfcourse.filter import ParticleFilter
from pfcourse.kalman import kalman_filter
from pfcourse.proposals import FullyAdaptedAuxiliary, LinearGaussianOptimal, OptimalProposal
from pfcourse.landmarks.rao_blackwell import RaoBlackwellModel, RaoBlackwellProposal
from pfcourse.landmarks.scenario import LandmarkScenario, circle_scenario, quadrant_scenario, simulate
from pfcourse.seeding import study_filter_seed

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
#: The stored study (``rao_blackwell`` in :mod:`pfcourse.experiments.registry`): N per scenario, seeds 0-99.
N_VALUES = {"quadrant": [30, 100, 300, 1000, 3000], "circle": [100, 1000]}
N_STEPS = 50  # both scenarios' ``n_samples``: columns nees_00 .. nees_49
COLUMNS = ("scenario", "method", "N", "seed", "landmark_error", "robot_error", "loglik_error", "ess",
           "seconds_per_step", *(f"nees_{k:02d}" for k in range(N_STEPS)))


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


def row(seed: int, scenario: str, method: str, N: int) -> dict:
    """One row (``run_study``'s ``run_one``): simulation ``seed`` of ``scenario`` filtered by ``method``
    with ``N`` particles (filter seed ``seed + 10**6``), or the Kalman filter's own row (``method="kalman"``)."""
    sc = SCENARIOS[scenario]()
    sim = simulate(sc, rng=seed)
    kf = kalman_filter(sc.model(), sim.measurements)
    if method == "kalman":
        return dict(scenario=scenario, method="kalman", N=0, seed=seed, landmark_error=0.0,
                    robot_error=0.0, loglik_error=0.0, ess=1.0, seconds_per_step=0.0,
                    **{f"nees_{k:02d}": v for k, v in enumerate(nees(sim.truth, kf.mean, kf.cov))})
    measured = sim.seen.any(axis=1)
    nr = 2
    run, first_stage = make_filter(method, sc, N)
    start = time.perf_counter()
    res = run(sim.measurements, study_filter_seed(seed))
    seconds = (time.perf_counter() - start) / len(sim.measurements)
    err = res.mean[-1] - kf.mean[-1]
    ess = np.array(first_stage) if first_stage is not None else res.ess[measured]
    return dict(
        scenario=scenario, method=method, N=N, seed=seed,
        landmark_error=float(np.sqrt(np.mean(err[nr:] ** 2))),
        robot_error=float(np.sqrt(np.mean(err[:nr] ** 2))),
        loglik_error=res.log_likelihood - kf.log_likelihood,
        ess=float(np.mean(ess) / N),
        seconds_per_step=seconds,
        **{f"nees_{k:02d}": v for k, v in enumerate(nees(sim.truth, res.mean, res.cov))},
    )
