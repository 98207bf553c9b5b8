"""Stored studies of issue 42 on terrain navigation: the field's 2-D problem against a converged grid,
the map error carried as a state, and the costs of the terrain filters timed in one run.

* ``terrain_field`` (:func:`field_row`): flight ``r`` of the 2-D problem of :mod:`pfcourse.scenarios.terrain.field`
  (drawn from :func:`pfcourse.seeding.data_rng` ``(0, r)``), filtered by the point-mass filter at
  :data:`FIELD_CELLS` and by the bootstrap particle filter with N = 3000 (multinomial resampling at
  ESS < N/2, :func:`pfcourse.seeding.filter_rng` ``(0, r)``): final posterior mean and standard deviations.
* ``terrain_map_bias`` (:func:`map_bias_row`): the flights of ``terrain_map_error`` (flight ``r`` of the
  4-D scenario over the true DEM, the filter on :func:`pfcourse.scenarios.terrain.map.mismatched_map` drawn from
  :func:`pfcourse.seeding.map_error_rng` ``(0, r)``), filtered by the marginalised filter (N = 3000) as it is,
  with ``Rf`` inflated by the readings per correlation length, and with a map-bias state
  (:mod:`pfcourse.scenarios.terrain.map_bias`), each at 1 Hz (``dt = 1 s``) and at 10 Hz (``dt = 0.1 s``).
* ``terrain_costs`` (:func:`cost_row`): every filter of the terrain decision timed on flights 0-9, one
  after the other in one process (each run twice, the second timed: the first compiles the kernels).
"""

from __future__ import annotations

import time

import numpy as np

from pfcourse.errors import ParameterError
from pfcourse.studies import terrain_marginalised, terrain_remedies
from pfcourse.studies.terrain import flight_scores, jacksboro
from pfcourse.jitter import RegularisedJitter
from pfcourse.filter_config import FilterConfig, FilterSettings, configurations, lookup
from pfcourse.seeding import data_rng, filter_rng, map_error_rng
from pfcourse.scenarios.terrain.field import FieldModel, FieldPointMass, FieldScenario, simulate_field
from pfcourse.scenarios.terrain.kalman import unscented_kalman_filter
from pfcourse.scenarios.terrain.map import MAP_ERROR_CORRELATION_CELLS, mismatched_map
from pfcourse.scenarios.terrain.map_bias import BiasKalmanProposal, MapBiasTerrainModel, correlation_length, inflated_rf
from pfcourse.scenarios.terrain.scenario import AircraftScenario, extended_kalman_filter, simulate

#: The 2-D study's settings: the point-mass filter at 50, 25 and 12.5 m cells, and the bootstrap filter.
FIELD_CELLS = [50.0, 25.0, 12.5]
FIELD_SETTINGS = [f"grid {c:g} m" for c in FIELD_CELLS] + ["bootstrap N=3000"]
FIELD_COLUMNS = ("setting", "flight", "final_x", "final_y", "final_sd_x", "final_sd_y", "final_error", "true_x",
                 "true_y", "seconds")
FIELD_FLIGHTS = 50
#: The particle filter of ``terrain_field``: bootstrap, N = 3000, multinomial resampling at ESS < N/2.
FIELD_PF = FilterSettings(3000, threshold=0.5, resampler="multinomial")


def field_row(seed: int, setting: str) -> dict:
    """Flight ``seed`` of the 2-D problem filtered with ``setting``: final mean and sd (m), final error (m)."""
    if setting not in FIELD_SETTINGS:
        raise ParameterError(f"unknown setting {setting!r}; known: {FIELD_SETTINGS}")
    terrain, scenario = jacksboro(), FieldScenario()
    flight = simulate_field(scenario, terrain, data_rng(0, seed))
    if setting.startswith("grid"):
        res = FieldPointMass(terrain, scenario, cell=float(setting.split()[1])).run(flight.readings)
        mean, sd = res.mean[-1], res.sd[-1]
    else:
        pf = FIELD_PF.build(FieldModel(terrain, scenario))
        res = pf.run(flight.readings[:, None], rng=filter_rng(0, seed))
        mean, sd = res.mean[-1], np.sqrt(np.diag(res.cov[-1]))
    return {"setting": setting, "flight": seed, "final_x": float(mean[0]), "final_y": float(mean[1]),
            "final_sd_x": float(sd[0]), "final_sd_y": float(sd[1]),
            "final_error": float(np.hypot(*(mean - flight.truth[-1]))),
            "true_x": float(flight.truth[-1, 0]), "true_y": float(flight.truth[-1, 1])}


#: The field problem's other particle filters (``book/data/terrain_field_pf.csv``): the regularised
#: filter (kernel at 0.2 x the optimal bandwidth after each resampling, as in the 4-D problem) with
#: N = 3000, and the bootstrap filter with N = 30 000, on the flights and filter seeds of ``terrain_field``.
FIELD_PF_SETTINGS = {"regularised N=3000": (3000, 0.2), "bootstrap N=30000": (30000, None)}
#: The same as settings records: ``FIELD_PF_FILTERS[setting].build(FieldModel(terrain, scenario))``.
FIELD_PF_FILTERS: dict[str, FilterConfig] = configurations(*(
    FilterConfig.of(name, FIELD_PF.with_(n_particles=n, jitter=None if scale is None else RegularisedJitter(scale)))
    for name, (n, scale) in FIELD_PF_SETTINGS.items()))


def field_pf_row(seed: int, setting: str) -> dict:
    """Flight ``seed`` of the 2-D problem filtered with ``setting`` of :data:`FIELD_PF_SETTINGS`: final mean
    and sd (m), final error (m), truth, as :func:`field_row`."""
    if setting not in FIELD_PF_SETTINGS:
        raise ParameterError(f"unknown setting {setting!r}; known: {list(FIELD_PF_SETTINGS)}")
    terrain, scenario = jacksboro(), FieldScenario()
    flight = simulate_field(scenario, terrain, data_rng(0, seed))
    pf = FIELD_PF_FILTERS[setting].build(FieldModel(terrain, scenario))
    res = pf.run(flight.readings[:, None], rng=filter_rng(0, seed))
    mean, sd = res.mean[-1], np.sqrt(np.diag(res.cov[-1]))
    return {"setting": setting, "flight": seed, "final_x": float(mean[0]), "final_y": float(mean[1]),
            "final_sd_x": float(sd[0]), "final_sd_y": float(sd[1]),
            "final_error": float(np.hypot(*(mean - flight.truth[-1]))),
            "true_x": float(flight.truth[-1, 0]), "true_y": float(flight.truth[-1, 1])}


#: The map-bias study: (rate, remedy) settings, flights 0-49 (those of terrain_map_error).
MAP_BIAS_RATES = {"1 Hz": {}, "10 Hz": {"measurement_period": 0.1, "dt": 0.1}}
MAP_BIAS_REMEDIES = ["marginalised", "R inflated", "bias state"]
MAP_BIAS_SETTINGS = [f"{rate}: {remedy}" for rate in MAP_BIAS_RATES for remedy in MAP_BIAS_REMEDIES]
MAP_BIAS_COLUMNS = ("setting", "flight", "status", "error_message", "final_error", "mean_error", "lost", "map_error_sd",
                    "length", "seconds")
MAP_BIAS_FLIGHTS = 50
MAP_BIAS_N = 3000
#: The study's filters as settings records, by remedy: the marginalised filter (also with ``R`` inflated, a change
#: to the scenario), and the marginalised filter with a map-bias state, built on
#: ``MapBiasTerrainModel(map, scenario, map_sd, length)`` with the flight's map error (``map_sd``, ``length``).
MAP_BIAS_FILTERS = {"marginalised": terrain_marginalised.MPF.with_(n_particles=MAP_BIAS_N),
                    "R inflated": terrain_marginalised.MPF.with_(n_particles=MAP_BIAS_N),
                    "bias state": FilterSettings(MAP_BIAS_N, threshold=0.5, resampler="multinomial",
                                                 proposal=BiasKalmanProposal())}


def map_bias_row(seed: int, setting: str) -> dict:
    """Flight ``seed`` over the true DEM, the marginalised filter on the mismatched map with ``setting``."""
    if setting not in MAP_BIAS_SETTINGS:
        raise ParameterError(f"unknown setting {setting!r}; known: {MAP_BIAS_SETTINGS}")
    rate, remedy = setting.split(": ")
    world = jacksboro()
    seen = mismatched_map(world, map_error_rng(0, seed))
    sd = float(np.std(seen.heights - world.heights))
    length = correlation_length(world, MAP_ERROR_CORRELATION_CELLS)
    scenario = AircraftScenario().with_(**MAP_BIAS_RATES[rate])
    flight = simulate(scenario, world, data_rng(0, seed))
    if remedy == "bias state":
        pf = MAP_BIAS_FILTERS[remedy].build(MapBiasTerrainModel(seen, scenario, sd, length))
    else:
        sc = scenario.with_(Rf=inflated_rf(scenario, sd, length)) if remedy == "R inflated" else scenario
        pf = MAP_BIAS_FILTERS[remedy].build(sc.model(seen))
    res = pf.run(flight.measurements, rng=filter_rng(0, seed))
    return {"setting": setting, "flight": seed, **flight_scores(flight.truth, res.mean), "map_error_sd": sd,
            "length": length}


#: The filters of the terrain decision, timed (terrain_costs): name -> (column id, particles; 0: a Kalman filter).
COST_FILTERS = {"EKF": ("ekf", 0), "UKF": ("ukf", 0), "bootstrap N=3000": ("boot3k", 3000),
                "marginalised N=3000": ("mpf3k", 3000), "bias state N=3000": ("bias3k", 3000),
                "regularised N=30000": ("rpf30k", 30000), "bootstrap N=30000": ("boot30k", 30000)}
COST_TIMES = tuple(f"cpu_{c}" for c, _ in COST_FILTERS.values())
COST_COLUMNS = ("timed", "flight", "steps", *(f"completed_{c}" for c, _ in COST_FILTERS.values()), *COST_TIMES)
COST_FLIGHTS = 10
COST_REPEATS = 2


def _run_cost_filter(setting: str, scenario: AircraftScenario, terrain, flight, seed: int) -> bool:
    """Run ``setting`` on ``flight``; ``True`` when it ends on the map (a Kalman filter may leave it; a particle
    filter that loses every particle raises, and the study, run with ``failures="raise"``, stops)."""
    if setting == "EKF":
        return extended_kalman_filter(scenario, terrain, flight.measurements).lost_at is None
    if setting == "UKF":
        return unscented_kalman_filter(scenario, terrain, flight.measurements).lost_at is None
    if setting == "marginalised N=3000":
        pf = MAP_BIAS_FILTERS["marginalised"].build(scenario.model(terrain))
    elif setting == "bias state N=3000":
        pf = MAP_BIAS_FILTERS["bias state"].build(MapBiasTerrainModel(terrain, scenario, 12.0, 300.0))
    else:
        pf = lookup(terrain_remedies.FILTERS, setting).build(scenario.model(terrain))
    pf.run(flight.measurements, rng=filter_rng(0, seed))  # every particle lost: raises, the study refuses it
    return True


def cost_row(seed: int, timed: str = "terrain decision") -> dict:
    """Every filter of :data:`COST_FILTERS` on flight ``seed``, in one process: a warm-up round (the kernels
    compile), then :data:`COST_REPEATS` rounds, each running the filters in an order that rotates with the
    round and the flight; the CPU time (``time.process_time``, s) of each filter's fastest round."""
    terrain, scenario = jacksboro(), AircraftScenario()
    flight = simulate(scenario, terrain, data_rng(0, seed))
    names = list(COST_FILTERS)
    completed = {name: _run_cost_filter(name, scenario, terrain, flight, seed) for name in names}
    best = dict.fromkeys(names, np.inf)
    for round_ in range(COST_REPEATS):
        shift = (seed + round_) % len(names)
        for name in names[shift:] + names[:shift]:
            start = time.process_time()
            _run_cost_filter(name, scenario, terrain, flight, seed)
            best[name] = min(best[name], time.process_time() - start)
    out = {"flight": seed, "steps": scenario.n_steps}
    out.update({f"completed_{COST_FILTERS[n][0]}": completed[n] for n in names})
    out.update({f"cpu_{COST_FILTERS[n][0]}": best[n] for n in names})
    return out


def map_error_family(map_error_lost, map_bias_lost, true_map: dict) -> dict:
    """Every comparison of lost flights the map-error studies make, as ``{name: (PairedRates, Holm p)}``.

    ``map_error_lost``: flights x settings of ``terrain_map_error`` (booleans); ``map_bias_lost``: the same for
    ``terrain_map_bias``; ``true_map``: for each setting of ``terrain_map_error`` run on the true map too, its
    lost flags there on the same flights.  Each comparison is an exact McNemar test on the paired flights
    (:func:`pfcourse.evidence.paired_rates`); Holm's adjustment (:func:`pfcourse.evidence.holm`) is over the
    whole family, so a claim that survives it survives having looked at all of them.
    """
    from pfcourse import evidence

    best, hz, told = "regularised N=30000", "regularised N=30000, 10 Hz", "regularised N=30000, Rf + map error"
    pairs = {f"{name}, map error vs true map": (map_error_lost[name], lost) for name, lost in true_map.items()}
    pairs.update({"regularised, 10 Hz vs 1 Hz": (map_error_lost[hz], map_error_lost[best]),
                  "regularised, Rf + map variance vs Rf": (map_error_lost[told], map_error_lost[best])})
    for rate in MAP_BIAS_RATES:
        for remedy in MAP_BIAS_REMEDIES[1:]:
            pairs[f"marginalised {rate}, {remedy} vs none"] = (map_bias_lost[f"{rate}: {remedy}"],
                                                               map_bias_lost[f"{rate}: marginalised"])
        pairs[f"marginalised {rate}, bias state vs R inflated"] = (map_bias_lost[f"{rate}: bias state"],
                                                                  map_bias_lost[f"{rate}: R inflated"])
    for remedy in MAP_BIAS_REMEDIES:
        pairs[f"marginalised, {remedy}, 10 Hz vs 1 Hz"] = (map_bias_lost[f"10 Hz: {remedy}"],
                                                          map_bias_lost[f"1 Hz: {remedy}"])
    tests = {name: evidence.paired_rates(a, b) for name, (a, b) in pairs.items()}
    adjusted = evidence.holm([t.pvalue for t in tests.values()])
    return {name: (t, float(p)) for (name, t), p in zip(tests.items(), adjusted)}
