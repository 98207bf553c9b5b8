"""The lab report's terrain studies, re-run on a baseline that works, one (setting, flight) at a time.

The report varied ``Q_f``, ``R_f``, ``N``, the resampling threshold, a measurement gap, the
measurement period and the resampling scheme around a bootstrap filter with ``N = 3000`` that
loses two flights in three (:mod:`pfcourse.studies.terrain_remedies`). Here every study
varies one thing around the **regularised filter** of the terrain-cure chapter
(``N = 30000``, multinomial resampling at ``ESS < N/2``, Gaussian kernel at 0.2 times the
optimal bandwidth, :class:`pfcourse.jitter.RegularisedJitter`), which loses about one flight
in twenty, so that a study compares accuracies rather than divergence noise.

Flight ``r`` is drawn from :func:`pfcourse.seeding.data_rng` ``(0, r)`` and the filter from
:func:`pfcourse.seeding.filter_rng` ``(0, r)`` for every setting (common random numbers), the seeds of
``book/data/terrain_remedies.csv``: the baseline's rows are that table's
``"regularised N=30000"`` rows. The study ``terrain_studies`` of
:mod:`pfcourse.studies.registry` (``python3 tasks.py study terrain_studies``) writes
``book/data/terrain_studies.csv``; ``tests/test_stored_studies.py`` re-computes a seeded sample.
"""

from __future__ import annotations

import numpy as np

from pfcourse.errors import ParameterError
from pfcourse.studies.terrain import flight_scores, jacksboro
from pfcourse.filter_config import FilterSettings
from pfcourse.jitter import RegularisedJitter
from pfcourse.seeding import data_rng, filter_rng
from pfcourse.metrics import position_spread
from pfcourse.scenarios.terrain.scenario import AircraftScenario, simulate

BASELINE_N = 30000
BASELINE_THRESHOLD = 0.5
BASELINE_SCHEME = "multinomial"
KERNEL_SCALE = 0.2

#: study -> {setting label: changes}; changes go to the scenario (``Qf_factor``, ``Rf``, ``gap``,
#: ``measurement_period``, ``dt``) or to the filter (``n_particles``, ``threshold``, ``resampler``).
#: The baseline is the setting ``"baseline"`` of the study ``"baseline"``, shared by every study.
STUDIES: dict[str, dict[str, dict]] = {
    "Qf": {"Qf x 0.1": {"Qf_factor": 0.1}, "Qf x 10": {"Qf_factor": 10.0}, "Qf x 100": {"Qf_factor": 100.0}},
    "Rf": {"Rf = 10^2": {"Rf": 10.0**2}, "Rf = 50^2": {"Rf": 50.0**2}, "Rf = 100^2": {"Rf": 100.0**2}},
    "N": {"N = 3000": {"n_particles": 3000}, "N = 10000": {"n_particles": 10000}},
    "threshold": {"threshold 0": {"threshold": 0.0}, "threshold 1": {"threshold": 1.0}},
    "gap": {"no readings 50-75 s": {"gap": (50.0, 75.0)}},
    "period": {"every 10 s": {"measurement_period": 10.0},
               "every 0.1 s, dt = 0.1 s": {"measurement_period": 0.1, "dt": 0.1}},
    "scheme": {"stratified": {"resampler": "stratified"}, "systematic": {"resampler": "systematic"}},
    "baseline": {"baseline": {}},
}

SCENARIO_KEYS = ("Qf_factor", "Rf", "gap", "measurement_period", "dt")
FILTER_KEYS = ("n_particles", "threshold", "resampler")
#: The stored columns of book/data/terrain_studies.csv, in order.
COLUMNS = ("study", "setting", "flight", "status", "error_message", "final_error", "mean_error", "lost", "sigma_50",
           "sigma_75", "resamplings", "median_ess_fraction", "seconds")


def settings() -> list[tuple[str, str]]:
    """Every ``(study, setting)`` pair, the baseline last."""
    return [(study, name) for study, group in STUDIES.items() for name in group]


def configure(study: str, setting: str, scenario: AircraftScenario | None = None):
    """``(scenario, filter options)`` of a setting: the baseline with the setting's changes."""
    if study not in STUDIES or setting not in STUDIES[study]:
        raise ParameterError(f"unknown study/setting {study!r}/{setting!r}; known: {settings()}")
    changes = dict(STUDIES[study][setting])
    scenario = scenario or AircraftScenario()
    sc = {k: changes.pop(k) for k in SCENARIO_KEYS if k in changes}
    if "Qf_factor" in sc:
        sc["Qf"] = scenario.Qf * sc.pop("Qf_factor")
    options = {"n_particles": BASELINE_N, "threshold": BASELINE_THRESHOLD, "resampler": BASELINE_SCHEME}
    options.update({k: changes.pop(k) for k in FILTER_KEYS if k in changes})
    if changes:
        raise ParameterError(f"unknown changes {changes}")
    return (scenario.with_(**sc) if sc else scenario), options


def filter_settings(options: dict) -> FilterSettings:
    """The filter of a setting's ``options`` (:func:`configure`) as a settings record: the regularised filter
    (its kernel ``KERNEL_SCALE`` times the optimal bandwidth, component 3, the heading, an angle:
    :class:`~pfcourse.jitter.RegularisedJitter`) with the setting's ``N``, threshold and scheme."""
    return FilterSettings(options["n_particles"], threshold=options["threshold"], resampler=options["resampler"],
                          jitter=RegularisedJitter(KERNEL_SCALE, (3,)))


def filter_records() -> dict[str, dict]:
    """``{"study/setting": record}``: every setting's filter as data (its provenance)."""
    return {f"{study}/{setting}": filter_settings(configure(study, setting)[1]).record() for study, setting in settings()}


def study_row(study: str, setting: str, flight: int, terrain, filter_terrain=None) -> dict:
    """Filter flight ``flight`` with a setting: errors (m), lost flag, sigma at 50 and 75 s, resamplings, ESS.
    The flight is flown over ``terrain``; the filter uses ``filter_terrain`` (default: the same map)."""
    scenario, options = configure(study, setting)
    sim = simulate(scenario, terrain, data_rng(0, flight))
    pf = filter_settings(options).build(scenario.model(terrain if filter_terrain is None else filter_terrain))
    res = pf.run(sim.measurements, rng=filter_rng(0, flight))
    sigma = position_spread(res.cov)
    k50, k75 = (int(round(t / scenario.dt)) for t in (50.0, 75.0))
    measured = ~np.isnan(sim.measurements[:, 0])
    return {"study": study, "setting": setting, "flight": flight, **flight_scores(sim.truth, res.mean),
            "sigma_50": float(sigma[k50]), "sigma_75": float(sigma[k75]),
            "resamplings": int(res.n_resamples),
            "median_ess_fraction": float(np.median(res.ess[measured]) / options["n_particles"])}


def row(seed: int, study: str, setting: str) -> dict:
    """The study's row function (``run_study``'s ``run_one``): :func:`study_row` of flight ``seed``."""
    return study_row(study, setting, seed, jacksboro())
