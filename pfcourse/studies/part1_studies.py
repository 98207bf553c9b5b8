"""Two studies of Part I stored as tables: the optimal proposal against the bootstrap, and the
five-landmark model's three findings (SIS, SIR and the Rao-Blackwellised filter).

``proposals`` (chapter ``part1/proposals``): SIR with the bootstrap or the optimal importance
function, one row per (setting, proposal, seed), simulation seed ``s``, filter seed ``s + 10**6``
(:func:`~pfcourse.seeding.study_filter_seed`), the same for both proposals:

* ``lab``: the lab's model (static landmarks), ``N = 500``, threshold 1/3; ``ess`` is the mean
  ESS / N over the steps with a measurement (NaN in a run without one), ``robot`` and
  ``landmarks`` the RMS error of the filter mean against the Kalman mean over the last 10 steps,
  ``resampled`` the share of steps resampled;
* ``sharp`` and ``broad``: process noise 0.05^2 m^2 on every coordinate, the simulator's too, the
  measurement standard deviation 0.1 or 1 times the lab's, ``N = 200``, threshold 1/2;
  ``ess`` as above, ``ess_sum`` and ``n_measured`` its sum over the measured steps and their
  number (to pool all measured steps of all runs), ``rmse`` the mean over the steps of the RMS
  error against that model's Kalman mean over all six coordinates.

``rb_five_landmarks`` (chapter ``part1/rao_blackwell``): on the five-landmark model, SIS
(threshold 0), SIR (threshold 1/3) and the Rao-Blackwellised filter (FastSLAM 2.0, threshold
1/3), ``N = 100``, simulation seed ``s``, filter seed ``s + 10**6``: ``collapse`` (first step with
ESS < 1.5, NaN if none), ``lm_sd`` and ``robot_sd`` (filter sd / Kalman sd at the last step,
geometric mean over the coordinates) and ``robot_cover`` (share of the last 10 steps whose true
robot lies in the filter's 95 % ellipse).
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from pfcourse.diagnostics import nees
from pfcourse.studies.landmarks import score
from pfcourse.filter_config import FilterConfig, FilterSettings, configurations, lookup
from pfcourse.kalman import kalman_filter
from pfcourse.scenarios.landmarks.rao_blackwell import RaoBlackwellModel, RaoBlackwellProposal
from pfcourse.scenarios.landmarks.scenario import circle_scenario, quadrant_scenario, simulate
from pfcourse.proposals import OptimalProposal
from pfcourse.studies.rb_study import RaoBlackwellised
from pfcourse.seeding import study_filter_seed
from pfcourse import metrics

ROBOT, LANDMARKS = [0, 1], [2, 3, 4, 5]
LAST = 10
SETTINGS = ["lab", "sharp", "broad"]
PROPOSALS = ["bootstrap", "optimal"]
NOISE_SCALES = {"sharp": 0.1, "broad": 1.0}  # times the lab's measurement standard deviation
ALL_NOISE = 0.05**2  # m^2 per step on every coordinate (sharp and broad)
N_LAB, N_SWEEP = 500, 200
THRESHOLD_LAB, THRESHOLD_SWEEP = 1 / 3, 1 / 2
FIVE_METHODS = ["SIS", "SIR", "RBPF"]
N_FIVE = 100

#: The filters of ``proposals``, by ``"<setting>/<proposal>"`` (the two sweeps, ``sharp`` and ``broad``, share
#: theirs): ``N`` and threshold of the setting, the transition (bootstrap) or the optimal importance function.
FILTERS: dict[str, FilterConfig] = configurations(*(
    FilterConfig.of(f"{setting}/{proposal}", FilterSettings(n, threshold=tau, proposal=prop))
    for setting, n, tau in (("lab", N_LAB, THRESHOLD_LAB), ("sweep", N_SWEEP, THRESHOLD_SWEEP))
    for proposal, prop in (("bootstrap", None), ("optimal", OptimalProposal()))))
#: The filters of ``rb_five_landmarks``: SIS, SIR, and the Rao-Blackwellised filter (FastSLAM 2.0), N = 100.
FIVE_FILTERS: dict[str, FilterConfig] = configurations(*(FilterConfig.of(name, settings) for name, settings in [
    ("SIS", FilterSettings(N_FIVE, threshold=0.0)), ("SIR", FilterSettings(N_FIVE, threshold=1 / 3)),
    ("RBPF", FilterSettings(N_FIVE, threshold=1 / 3, proposal=RaoBlackwellProposal(True),
                            model_change=RaoBlackwellised()))]))
assert list(FIVE_FILTERS) == FIVE_METHODS


def noisy_scenario(setting: str):
    """The scenario of ``setting``: the lab's, or every coordinate noisy with the measurement noise scaled."""
    scenario = quadrant_scenario()
    if setting == "lab":
        return scenario
    q_all = scenario.Qw.copy()
    q_all[2:, 2:] = ALL_NOISE * np.eye(q_all.shape[0] - 2)
    return scenario.with_(Qw=q_all, Rv=NOISE_SCALES[setting] ** 2 * scenario.Rv)


def proposals_row(seed: int, setting: str, proposal: str) -> dict:
    """One run of the study ``proposals``."""
    if setting not in SETTINGS or proposal not in PROPOSALS:
        raise ValueError(f"unknown setting or proposal {setting!r}, {proposal!r}")
    scenario = noisy_scenario(setting)
    model = scenario.model()
    sim = simulate(scenario, rng=seed)
    kf = kalman_filter(model, sim.measurements)
    settings = FILTERS[f"{'lab' if setting == 'lab' else 'sweep'}/{proposal}"].settings
    n = settings.n_particles
    r = settings.build(model).run(sim.measurements, rng=study_filter_seed(seed))
    measured = sim.seen.any(axis=1)
    ess = r.ess[measured] / n
    out = {"ess": float(np.mean(ess)) if measured.any() else np.nan, "ess_sum": float(np.sum(ess)),
           "n_measured": int(measured.sum()), "resampled": float(np.mean(r.resampled))}
    if setting == "lab":
        err = (r.mean - kf.mean)[-LAST:]
        out.update(robot=float(metrics.rmse(err[:, ROBOT])),
                   landmarks=float(metrics.rmse(err[:, LANDMARKS])), rmse=np.nan)
    else:
        out.update(robot=np.nan, landmarks=np.nan, rmse=float(score(r, kf, sim.truth).scores["rmse"].mean()))
    return out


def five_landmarks_row(seed: int, method: str) -> dict:
    """One run of the study ``rb_five_landmarks``."""
    circle = circle_scenario()
    model = circle.model()
    sim = simulate(circle, rng=seed)
    kf = kalman_filter(model, sim.measurements)
    pf = lookup(FIVE_FILTERS, method, "method").settings.build(model)
    r = pf.run(sim.measurements, rng=study_filter_seed(seed))
    if isinstance(pf.model, RaoBlackwellModel):  # the RBPF's marginal over the full state
        r = pf.model.marginal(r)
    sd_ratio = np.sqrt(np.clip(np.diag(r.cov[-1]), 1e-300, None) / np.diag(kf.cov[-1]))
    limit2 = stats.chi2.ppf(0.95, 2)
    inside = nees(sim.truth[-LAST:, :2], r.mean[-LAST:, :2], r.cov[-LAST:, :2, :2]) <= limit2
    below = np.flatnonzero(r.ess < 1.5)
    return {"collapse": float(below[0]) if below.size else np.nan,
            "lm_sd": float(np.exp(np.mean(np.log(sd_ratio[2:])))),
            "robot_sd": float(np.exp(np.mean(np.log(sd_ratio[:2])))),
            "robot_cover": float(np.mean(inside))}
