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

The six filters are the named configurations :data:`FILTERS`, each a
:class:`~pfcourse.filter_config.FilterSettings` record.
Row ``method="kalman"`` (``N = 0``) holds the Kalman filter's own NEES.  The stored table lists,
for each scenario and seed, the Kalman row and then every method and ``N``.
"""

from __future__ import annotations

import time
import numpy as np

from pfcourse.diagnostics import nees
from pfcourse.filter_config import FilterConfig, FilterSettings, configurations, lookup
from pfcourse.kalman import kalman_filter
from pfcourse.proposals import FirstStageESS, FullyAdaptedAuxiliary, LinearGaussianOptimal, OptimalProposal
from pfcourse.scenarios.landmarks.rao_blackwell import RaoBlackwellModel, RaoBlackwellProposal
from pfcourse.scenarios.landmarks.scenario import LandmarkScenario, circle_scenario, quadrant_scenario, simulate
from pfcourse.seeding import study_filter_seed
from pfcourse import metrics

SCENARIOS = {"quadrant": quadrant_scenario, "circle": circle_scenario}
THRESHOLD = 1 / 3  # the lab's resampling threshold, as in the SIR chapter


class RaoBlackwellised:
    """The model change of the Rao-Blackwellised filters: the landmark model with the map integrated out
    (:class:`RaoBlackwellModel`, a Kalman filter of the landmarks in each particle)."""

    label = "Rao-Blackwellised"

    def apply(self, model) -> RaoBlackwellModel:
        return RaoBlackwellModel(model)


def _settings(threshold: float = THRESHOLD, proposal=None, rao_blackwellised: bool = False) -> FilterSettings:
    """A filter of the study (``N``: the grid's; 1000 nominal), systematic resampling at ESS < ``threshold`` N."""
    return FilterSettings(1000, threshold=threshold, proposal=proposal,
                          model_change=RaoBlackwellised() if rao_blackwellised else None)


#: The six filters, in the order of the chapter, as settings records: ``config.settings.with_(n_particles=N)
#: .build(scenario.model())`` (a filter on a :class:`RaoBlackwellModel` integrates the map out; :func:`run_config`
#: returns its marginal over the full state).  The auxiliary filters resample at every step (threshold 1).
FILTERS: dict[str, FilterConfig] = configurations(*(FilterConfig.of(name, settings, n_from_grid=True) for name, settings in [
    ("sir", _settings()),
    ("sir_optimal", _settings(proposal=OptimalProposal())),
    ("apf", _settings(1.0, FullyAdaptedAuxiliary(LinearGaussianOptimal()))),
    ("rbpf_prior", _settings(proposal=RaoBlackwellProposal(optimal=False), rao_blackwellised=True)),
    ("rbpf_optimal", _settings(proposal=RaoBlackwellProposal(optimal=True), rao_blackwellised=True)),
    ("rb_apf", _settings(1.0, FullyAdaptedAuxiliary(RaoBlackwellProposal(optimal=True)), rao_blackwellised=True)),
]))
#: name -> the chapters' name of each filter (legends and tables; the settings are in ``FILTERS[name].label``)
METHODS: dict[str, str] = {"sir": "SIR, bootstrap", "sir_optimal": "SIR, optimal proposal",
                           "apf": "auxiliary PF (fully adapted)", "rbpf_prior": "RBPF, prior proposal (FastSLAM 1.0)",
                           "rbpf_optimal": "RBPF, optimal proposal (FastSLAM 2.0)",
                           "rb_apf": "RBPF, auxiliary (fully adapted)"}
#: The stored study (``rao_blackwell`` in :mod:`pfcourse.studies.registry`): N per scenario, seeds 0-99.
N_VALUES = {"quadrant": [30, 100, 300, 1000, 3000], "circle": [100, 1000]}
N_STEPS = 50  # both scenarios' ``n_samples``: columns nees_00 .. nees_49
COLUMNS = ("scenario", "method", "N", "seed", "landmark_error", "robot_error", "loglik_error", "ess",
           "seconds_per_step", *(f"nees_{k:02d}" for k in range(N_STEPS)))


def run_config(method: str, scenario: LandmarkScenario, n_particles: int, Z, seed) -> tuple:
    """Run the filter ``method`` of :data:`FILTERS` on ``Z``: its result over the full state (the
    marginal of a Rao-Blackwellised filter) and the first-stage ESS of an auxiliary filter at the steps
    that drew a first stage, collected per step (:class:`~pfcourse.proposals.FirstStageESS`; else ``None``)."""
    pf = lookup(FILTERS, method).settings.with_(n_particles=n_particles).build(scenario.model())
    auxiliary = isinstance(pf.proposal, FullyAdaptedAuxiliary)
    res = pf.run(Z, seed, collect=[FirstStageESS()] if auxiliary else [])
    first_stage = res.collected["first_stage_ess"] if auxiliary else None
    if isinstance(pf.model, RaoBlackwellModel):
        res = pf.model.marginal(res)
    return res, None if first_stage is None else first_stage[~np.isnan(first_stage)]


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
    start = time.perf_counter()
    res, first_stage = run_config(method, sc, N, sim.measurements, study_filter_seed(seed))
    seconds = (time.perf_counter() - start) / len(sim.measurements)
    err = res.mean[-1] - kf.mean[-1]
    ess = np.array(first_stage) if first_stage is not None else res.ess[measured]
    return dict(
        scenario=scenario, method=method, N=N, seed=seed,
        landmark_error=float(metrics.rmse(err[nr:])),
        robot_error=float(metrics.rmse(err[:nr])),
        loglik_error=res.log_likelihood - kf.log_likelihood,
        ess=float(np.mean(ess) / N),
        seconds_per_step=seconds,
        **{f"nees_{k:02d}": v for k, v in enumerate(nees(sim.truth, res.mean, res.cov))},
    )
