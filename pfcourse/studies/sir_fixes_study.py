"""SIR's two fixes on scenario A, swept over N: report 000's landmark noise, read two ways, and roughening.

Report 000 adds landmark process noise (variance 0.0025 m^2 per step) and shows the ``Qw``
that its simulator returns, so it can be read two ways:

* ``noise_filter_only``: the simulator keeps the landmarks static, the filter's model has
  the noise (a mismatched model; reference: the Kalman filter of the static model, the
  exact posterior of the data);
* ``noise_everywhere``: simulator and filter both have it (the filter's model is exact;
  reference: the Kalman filter of that model).

``roughening_K`` is SIR on the static model with roughening of constant ``K`` after each
resampling (:mod:`pfcourse.jitter`); ``sir`` is plain SIR (K = 0).  One row per
(variant, N, seed): simulation seed ``s``, filter seed ``s + 10**6``, threshold N/3
(the study ``sir_fixes`` of :mod:`pfcourse.studies.registry`, seeds ``s = 0 .. 99``).
Scores over the last 10 steps, on the four landmark coordinates: ``error`` (mean over the
steps of the RMS error of the filter mean against the reference Kalman mean, m) and
``coverage`` (share of the steps whose truth lies inside the filter's 95 % ellipsoid).
"""

from __future__ import annotations

import numpy as np

from pfcourse.studies.landmarks import score
from pfcourse.filter_config import FilterConfig, FilterSettings, configurations, lookup
from pfcourse.kalman import kalman_filter
from pfcourse.scenarios.landmarks.scenario import quadrant_scenario, simulate
from pfcourse.jitter import Roughening
from pfcourse.seeding import study_filter_seed

LANDMARKS = [2, 3, 4, 5]
LANDMARK_NOISE = 0.0025  # m^2 per step, report 000's value
VARIANTS = ["sir", "noise_filter_only", "noise_everywhere",
            "roughening_0.05", "roughening_0.1", "roughening_0.2", "roughening_0.4"]
N_VALUES = [100, 300, 1000, 3000]
THRESHOLD = 1 / 3


def _settings(jitter=None) -> FilterSettings:
    """SIR at ESS < N/3, systematic resampling (``N``: the grid's; 1000 nominal), with ``jitter`` after it."""
    return FilterSettings(1000, threshold=THRESHOLD, jitter=jitter)


#: The filter of each variant: ``FILTERS[variant].settings.with_(n_particles=N).build(model)``.  The two
#: noise variants run plain SIR; what differs is the model (:func:`variant_row`), not the filter.
FILTERS: dict[str, FilterConfig] = configurations(*(FilterConfig.of(variant, settings, n_from_grid=True)
                                                    for variant, settings in [
    ("sir", _settings()), ("noise_filter_only", _settings()), ("noise_everywhere", _settings()),
    *((f"roughening_{k}", _settings(Roughening(k))) for k in (0.05, 0.1, 0.2, 0.4))]))
assert list(FILTERS) == VARIANTS


def noisy_q(scenario):
    """The scenario's ``Qw`` with ``LANDMARK_NOISE`` on the landmark coordinates."""
    q = scenario.Qw.copy()
    q[2:, 2:] = LANDMARK_NOISE * np.eye(q.shape[0] - 2)
    return q


def variant_row(variant: str, n_particles: int, seed: int) -> dict:
    """Run one variant (``sir``, ``noise_filter_only``, ``noise_everywhere``, ``roughening_<K>``)."""
    settings = lookup(FILTERS, variant, "variant").settings.with_(n_particles=n_particles)
    static = quadrant_scenario()
    sim_scenario = static
    filter_model = static.model()
    if variant == "noise_filter_only":
        filter_model = static.model(Qw=noisy_q(static))
    elif variant == "noise_everywhere":
        sim_scenario = static.with_(Qw=noisy_q(static))
        filter_model = sim_scenario.model()
    sim = simulate(sim_scenario, rng=seed)
    reference = kalman_filter(sim_scenario.model(), sim.measurements)
    pf = settings.build(filter_model)
    s = score(pf.run(sim.measurements, study_filter_seed(seed)), reference, sim.truth, LANDMARKS)
    return dict(variant=variant, N=n_particles, seed=seed,
                error=float(s.rmse[-10:].mean()), coverage=float(s.covered[-10:].mean()))


def row(seed: int, variant: str, N: int) -> dict:
    """The study's row function (``run_study``'s ``run_one``): :func:`variant_row`."""
    return variant_row(variant, N, seed)
