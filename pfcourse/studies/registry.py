"""The book's stored studies, each one record registered here, run one way and stored one way.

A study too heavy to run while the book executes is a :class:`Study`: a name, a grid of
settings, a row function ``row(seed=..., **setting) -> metrics``, a number of runs and the
rule that gives run ``r`` its seed, one failure policy, and where its table is stored.
Every study is run by :func:`pfcourse.studies.study.run_study` (on any executor) and
stored by :mod:`pfcourse.studies.store`, its provenance beside it
(:func:`pfcourse.studies.provenance.write_provenance`)::

    python3 tasks.py study NAME       # NAME: a study, or a group such as robot_studies

``tests/test_stored_studies.py`` re-computes a seeded sample of every registered study's
stored rows (among its ``cheap`` rows) from their recorded settings and seeds, and requires
the same numbers, float for float, and checks that each table
has exactly the settings, seeds and order its record describes.

**One schema.** A stored table has a column per grid parameter (its name in the grid, its values
as the grid gives them; those that are neither numbers nor words, ``None`` or tuples, as Python
literals: :attr:`Study.literals`), the run's seed in ``seed_column``, then ``status`` and ``error_message`` (text, ``""`` for a run that
did not fail) where the table keeps them, the metrics of the row function, per-step columns in
``NAME.npz``.  What made it is in its provenance record, the configurations of its filters as
data (:meth:`pfcourse.filter_config.FilterSettings.record`).  The tables of older scripts were
converted to this schema once (``tools/convert_stored_studies.py``, checked by
``tests/test_converted_studies.py``).

**Adding a study**: write its row function in the experiments module of its scenario (a
module-level function, so that a process pool can send it), add a :class:`Study` to
:data:`STUDIES` below (its ``filters``: the settings records its rows build, written into the provenance), run ``python3 tasks.py study NAME`` after committing the code (the
provenance names the commit), and commit the table.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import platform
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime, timezone
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pfcourse.errors import ParameterError, StepError
from pfcourse.checks import check_count
from pfcourse.filter_config import FilterConfig, FilterSettings, records
from pfcourse.studies import association, comparison, count_resampling, global_localization, intel, map_global
from pfcourse.studies import map_global_challenger as mgc
from pfcourse.studies import map_global_islands as mgi
from pfcourse.studies import intel_clusters
from pfcourse.studies import likelihood_studies as ls
from pfcourse.studies import part1_studies
from pfcourse.studies import static_parameters_study as sps
from pfcourse.studies import pmcmc_studies as pm
from pfcourse.studies import (maprobot, rb_study, robot_studies, sir_fixes_study, smoothing_studies,
                                  terrain_field, terrain_marginalised, terrain_remedies, terrain_studies,
                                  why_it_works)
from pfcourse.studies.provenance import append_rerun, launch_commit, tree_modified, write_provenance
from pfcourse.studies.robot import pf_run
from pfcourse.studies import robot as robot_experiments
from pfcourse.studies.store import DATA, load, save
from pfcourse.studies.terrain import LOST_FLIGHT
from pfcourse.scenarios.robot import mcl as robot_mcl
from pfcourse.studies.executor import SerialExecutor
from pfcourse.studies.study import grid_settings, run_study
from pfcourse.seeding import replicate_seed

#: Seed rules: the seed of run ``r`` of a study with base seed ``b``.
SEED_RULES: dict[str, Callable[[int, int], int]] = {
    "replicate": replicate_seed,  # run_study's default: SeedSequence([b, r])
    "run": lambda b, r: b + r,  # the run's number, counted from b (a flight, a simulation seed)
}
#: Failure policies: ``record`` keeps a collapsed run as a row with ``status="failed"``, its
#: message and the study's ``failed_scores`` (run_study's rule); ``raise`` refuses to store a table
#: with a collapsed run (its table has no status column).
FAILURES = ("record", "raise")


def _check_data_path(study: str, name: str, path) -> None:
    """A table or provenance path must be a relative path to a file inside book/data."""
    suffix = {"table": ".csv", "provenance": ".json"}[name]
    if not isinstance(path, str) or not path.endswith(suffix):
        raise ParameterError(f"study {study}: {name} must be a {suffix} file name under book/data, got {path!r:.60}")
    parts = Path(path).parts
    if Path(path).is_absolute() or ".." in parts:
        raise ParameterError(f"study {study}: {name} must be a path inside book/data (relative, no '..'), "
                             f"got {path!r}")


@dataclass(frozen=True)
class Study:
    """One stored study: what to run, how it is seeded, and where its table goes.

    ``grid`` is one grid (``{parameter: values}``, every combination) or a tuple of grids
    run one after the other (settings that are not a product).  Run ``r`` of every setting has
    the seed ``SEED_RULES[seeds](base_seed, r)`` (common random numbers).  The table is run_study's rows,
    grid after grid, then stably sorted by ``order`` (each column in order of first
    appearance) and cut to ``columns`` (``None``: all).  A stored row's seed is in its
    ``seed_column``, and its setting in the grid's columns.
    """

    name: str
    row: Callable[..., Mapping]
    grid: Mapping[str, Sequence] | tuple[Mapping[str, Sequence], ...]
    n_runs: int
    table: str  # CSV path under book/data
    provenance: str  # JSON path under book/data (shared by the studies of a group)
    seeds: str = "replicate"
    base_seed: int = 0
    failures: str = "record"
    failed_scores: Mapping[str, Any] = field(default_factory=dict)  # a collapsed run's metrics (failures="record")
    columns: tuple[str, ...] | None = None
    order: tuple[str, ...] = ()
    seed_column: str = "seed"  # the column of the run's seed (a flight's number: "flight")
    arrays: tuple[str, ...] = ()  # per-step columns stored in NAME.npz (store.save)
    volatile: tuple[str, ...] = ("seconds",)  # wall times: never re-computed
    cheap: Callable[[pd.DataFrame], pd.Series] | None = None  # stored rows quick enough to re-compute
    sample: int = 2  # rows re-computed by the test
    row_code: str = ""
    fields: Mapping = field(default_factory=dict)  # the study's own provenance fields
    #: the particle filters its rows build, ``{name: FilterSettings or FilterConfig}`` (its provenance's ``filters``)
    filters: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ParameterError(f"a study needs a name (a non-empty string), got {self.name!r:.60}")
        if not callable(self.row):
            raise ParameterError(f"study {self.name}: row must be the function that runs one row, "
                                 f"got {type(self.row).__name__} {self.row!r:.40}")
        if isinstance(self.n_runs, bool) or not isinstance(self.n_runs, (int, np.integer)):
            raise ParameterError(f"study {self.name}: n_runs must be an integer >= 1, got {self.n_runs!r}")
        check_count(self.n_runs, f"study {self.name}: n_runs")
        if not isinstance(self.grid, (Mapping, tuple)) or (isinstance(self.grid, tuple) and not self.grid):
            raise ParameterError(f"study {self.name}: grid must be a dict {{parameter: values}} or a non-empty "
                                 f"tuple of them, got {self.grid!r:.60}")
        for grid in self.grids:
            try:
                grid_settings(grid)
            except ParameterError as exc:
                raise ParameterError(f"study {self.name}: {exc}") from None
        if not isinstance(self.filters, Mapping):
            raise ParameterError(f"study {self.name}: filters must be a dict {{name: FilterSettings}}, got {self.filters!r:.60}")
        self.filter_records()  # each a FilterSettings or a FilterConfig
        for name in ("table", "provenance"):
            _check_data_path(self.name, name, getattr(self, name))
        for name in ("columns", "order", "arrays", "volatile"):
            value = getattr(self, name)
            if value is None and name == "columns":
                continue
            if not isinstance(value, tuple) or not all(isinstance(v, str) for v in value):
                raise ParameterError(f"study {self.name}: {name} must be a tuple of column names, "
                                     f"got {value!r:.60}")
        if self.seeds not in SEED_RULES or self.failures not in FAILURES:
            raise ParameterError(f"study {self.name}: seeds must be one of {list(SEED_RULES)} and failures one "
                                 f"of {FAILURES}, got {self.seeds!r}, {self.failures!r}")
        if self.failed_scores and self.failures != "record":
            raise ParameterError(f"study {self.name}: failed_scores score the collapsed runs a table records; "
                                 f"give them with failures='record'")
        clash = {self.seed_column, "run"} & {key for grid in self.grids for key in grid}
        if clash:
            raise ParameterError(f"study {self.name}: a grid parameter cannot be named {sorted(clash)} "
                                 f"(the columns of the run and its seed)")

    def filter_records(self) -> dict[str, dict]:
        """``{name: record}`` of :attr:`filters`, plain data (JSON-ready): the label and the settings' record
        (:meth:`pfcourse.filter_config.FilterSettings.record`) of every filter the study's rows build."""
        out = {}
        for name, config in self.filters.items():
            if isinstance(config, FilterConfig):
                out[name] = config.record()
            elif isinstance(config, FilterSettings):
                out[name] = {"label": config.label, **config.record()}
            else:
                raise ParameterError(f"study {self.name}: filters[{name!r}] must be a FilterSettings or a "
                                     f"FilterConfig, got {type(config).__name__}")
        return json.loads(json.dumps(out))

    @property
    def grids(self) -> tuple[Mapping[str, Sequence], ...]:
        return (self.grid,) if isinstance(self.grid, Mapping) else tuple(self.grid)

    @property
    def literals(self) -> tuple[str, ...]:
        """The grid's columns holding values that are neither numbers nor words (``None``, tuples): stored
        as Python literals (:mod:`pfcourse.studies.store`)."""
        plain = (int, float, str, np.integer, np.floating)
        return tuple(dict.fromkeys(key for grid in self.grids for key, values in grid.items()
                                   if any(not isinstance(v, plain) for v in values)))

    @property
    def path(self) -> Path:
        return DATA / self.table

    def compute(self, n_runs: int | None = None, first: int = 0, **options) -> pd.DataFrame:
        """The study's table as it is stored (``options`` go to :func:`run_study`: ``executor``, ``progress``);
        only its runs ``first .. n_runs - 1`` when ``first`` is given (the rows :func:`extend` appends)."""
        n_runs = self.n_runs if n_runs is None else n_runs
        if not 0 <= first < n_runs:
            raise ParameterError(f"study {self.name}: first run {first} must be in 0 .. {n_runs - 1}")
        seeds = [SEED_RULES[self.seeds](self.base_seed, r) for r in range(first, n_runs)]
        options = {"progress": False, **options}
        table = pd.concat([run_study(self.row, grid, n_runs - first, seeds=seeds, failed_scores=self.failed_scores,
                                     **options) for grid in self.grids],
                          ignore_index=True)
        table["run"] += first
        if self.failures == "raise" and (table["status"] != "ok").any():
            failed = table[table["status"] != "ok"].iloc[0]
            raise StepError(f"study {self.name}: run {failed['run']} failed ({failed['error_message']})")
        # The stored seed comes from the runner, so that a failed run has it too.
        table[self.seed_column] = [SEED_RULES[self.seeds](self.base_seed, r) for r in table["run"]]
        table = self._ordered(table)
        return table.reindex(columns=list(self.columns)) if self.columns is not None else table  # NaN: no run gave it

    def layout(self, n_runs: int | None = None) -> pd.DataFrame:
        """Setting, ``run`` and ``seed`` of every row of the table, in the stored order (nothing is run)."""
        n_runs = self.n_runs if n_runs is None else n_runs
        rows = [{**setting, "run": r, "seed": SEED_RULES[self.seeds](self.base_seed, r)}
                for grid in self.grids for setting in grid_settings(grid) for r in range(n_runs)]
        return self._ordered(pd.DataFrame(rows))

    def _ordered(self, table: pd.DataFrame) -> pd.DataFrame:
        """``table`` stably sorted by ``order`` (each column in order of first appearance)."""
        if not self.order:
            return table
        keys = [pd.factorize(table[column])[0] for column in self.order]
        return table.iloc[np.lexsort(keys[::-1])].reset_index(drop=True)  # lexsort is stable

    def load(self) -> pd.DataFrame:
        """The stored table (as :meth:`compute` returns it, ``seconds`` as stored), its provenance
        record in ``table.attrs["provenance"]``: the one way a chapter reads a stored study."""
        if not self.path.exists():
            raise FileNotFoundError(f"{self.path} is missing: run `python3 tasks.py study {self.name}`")
        table = load(self.path, literals=self.literals, arrays=self.arrays)
        table.attrs["provenance"] = self.provenance_record()
        return table

    def provenance_record(self) -> dict:
        """The provenance record written beside the table (shared by the studies of a group)."""
        return json.loads((DATA / self.provenance).read_text())

    def save(self, table: pd.DataFrame) -> None:
        save(self.path, table, literals=self.literals, arrays=self.arrays)

    def setting(self, stored: Mapping) -> dict:
        """The grid setting of a stored row, with the grid's own values (as the study passed them)."""
        for grid in self.grids:
            setting = {}
            for key, values in grid.items():
                match = [v for v in values if same(v, stored[key])]
                if not match:
                    break
                setting[key] = match[0]
            else:
                return setting
        raise ParameterError(f"study {self.name}: no setting of its grid matches the stored row {dict(stored)!r:.200}")

    def recompute(self, stored: Mapping) -> Mapping:
        """Re-run one stored row from its setting and recorded seed."""
        return self.row(seed=int(stored[self.seed_column]), **self.setting(stored))


def same(a, b, rtol: float = 0.0) -> bool:
    """``a == b`` for settings and metrics (``None``, tuples, arrays, NaN equal to NaN), floats within ``rtol``."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(a, b, equal_nan=True)
    if isinstance(a, float) and isinstance(b, float) and not isinstance(a, bool):
        return bool(np.isclose(a, b, rtol=rtol, atol=0.0, equal_nan=True)) if rtol else (a == b or (np.isnan(a) and np.isnan(b)))
    try:
        return bool(a == b)
    except (TypeError, ValueError):
        return False


#: The particle filters of the Part V studies that build one in their rows (the others run the core's
#: likelihood estimators, :mod:`pfcourse.likelihood`).
LIKELIHOOD_FILTERS = {"smoothing_robot": {"bootstrap": ls.ROBOT_GAP_FILTER}}


def _likelihood_study(name: str, row: Callable, grid: dict, n_runs: int, base_seed: int, **options) -> Study:
    """A Part V study: run_study's table without its wall times, in book/data/likelihood/."""
    return Study(name=f"likelihood/{name}", row=row, grid=grid, n_runs=n_runs, base_seed=base_seed,
                 table=f"likelihood/{name}.csv", provenance=f"likelihood/{name}.json",
                 row_code=f"pfcourse/studies/likelihood_studies.py ({row.__name__})",
                 fields=ls.PROVENANCE_FIELDS[name], **{"filters": LIKELIHOOD_FILTERS.get(name, {}), **options})


def _mcl_study(name: str, row: Callable, grid, **options) -> Study:
    """A table of the global-localization chapter."""
    options = {"failures": "raise", "filters": robot_mcl.FILTERS, **options}
    return Study(name=f"global_localization/{name}", row=row, grid=grid, n_runs=100, seeds="run",
                 table=f"global_localization/{name}.csv", provenance="global_localization/provenance.json",
                 columns=global_localization.COLUMNS[name],
                 row_code=f"pfcourse/studies/global_localization.py ({row.__name__})", **options)


def _robot_filters(grid: dict, options: dict) -> dict:
    """The particle filter of each setting of a robot study, ``{"key=value, ...": FilterSettings}``
    (:meth:`pfcourse.studies.robot.RobotRunOptions.filter_settings`)."""
    return {", ".join(f"{k}={v!r}" for k, v in setting.items()) or "default":
            robot_experiments.RobotRunOptions.split({**robot_studies.DEFAULTS, **options, **setting})[0].filter_settings()
            for setting in grid_settings(grid)}


def _robot_study(name: str, grid: dict, options: dict) -> Study:
    return Study(filters=_robot_filters(grid, options), name=f"robot_studies/{name}", row=partial(pf_run, **{**robot_studies.DEFAULTS, **options}),
                 grid=grid, n_runs=robot_studies.N_RUNS, table=f"robot_studies/{name}.csv",
                 provenance="robot_studies/provenance.json", arrays=robot_studies.ARRAY_COLUMNS,
                 row_code="pfcourse/studies/robot.py (pf_run)", fields={"grid": grid, "options": options})


def _terrain_filters(settings) -> dict:
    """The terrain filters a study's settings run: ``{setting: FilterConfig}`` (a setting that is a filter of
    :data:`terrain_remedies.FILTERS` with a change to the scenario or the period runs that filter or the period
    study's; its scenario change is in the study's fields)."""
    out = {}
    for setting in settings:
        name = setting.split(", 10 Hz")[0].split(", Rf + map")[0]
        if setting.endswith(", 10 Hz"):
            out[setting] = terrain_studies.filter_settings(terrain_studies.configure("period", "every 0.1 s, dt = 0.1 s")[1])
        else:
            out[setting] = terrain_remedies.FILTERS[name]
    return out


#: The terrain flight studies record a filter that lost every particle as a lost flight (infinite error).
_FLIGHTS = {"failures": "record", "failed_scores": LOST_FLIGHT}
#: The global-localization runs record a filter that lost every particle as a failed run, not locked on.
_GLOBAL_RUNS = {"failures": "record", "failed_scores": global_localization.FAILED_RUN}

#: The known exceptions to the one schema, in one place (tests/test_study_records.py checks that no other
#: study has them): the terrain flight studies name their seed column after the flight it draws (``flight``,
#: as their chapters read it). (Four global-localization tables an older script stored with 10 significant
#: digits were re-stored at full precision by tools/restore_full_precision.py: every table round-trips.)
SCHEMA_EXCEPTIONS: dict[str, tuple[str, ...]] = {
    "seed_column flight": ("terrain_remedies", "terrain_reference", "terrain_studies", "terrain_map_error",
                           "terrain_error_paths", "terrain_model_flights", "terrain_equal_cost", "terrain_mpf",
                           "terrain_grid", "terrain_field", "terrain_field_pf", "terrain_map_bias", "terrain_costs",
                           "terrain_confirmation", "terrain_cost_matched"),
}
#: The stored studies whose rows build no particle filter through a settings record, so that their
#: provenance has no ``filters`` (:data:`pfcourse.studies.provenance.SCHEMA`), by name or group, with the reason.
NO_FILTER_RECORD: dict[str, str] = {
    "count_resampling": "the bootstrap filter of the count model in plain NumPy (count_resampling.bootstrap_means)",
    "likelihood/bias": "the core's likelihood estimator, pfcourse.likelihood.pf_log_likelihood",
    "likelihood/ml": "the core's likelihood estimator, pfcourse.likelihood.pf_log_likelihood",
    "likelihood/pmmh": "PMMH (pfcourse.pmmh), its particle filter built inside the sampler",
    "likelihood/terrain_rf": "the terrain likelihood estimator (pfcourse.likelihood)",
    "data_association_pdaf": "no particle filter: the PDA filter", "data_association_nn": "no particle filter: the NN-EKF",
    "map_global": "global_mcl's own loop (pfcourse.scenarios.maprobot.global_mcl), its GlobalSettings recorded",
    **{f"intel/{name}": "global_mcl's own loop (pfcourse.scenarios.maprobot.global_mcl), its GlobalSettings recorded"
       for name in ("global", "global_previous", "map_control", "guarded_maps", "map_control_margin", "injection",
                    "long_runs", "islands", "islands_map_control", "cluster_estimate")},
    "terrain_grid": "no particle filter: the point-mass grid filter", "terrain_costs": "timings of other studies' filters",
    "static_parameters": "the samplers of pfcourse.static_parameters (Liu-West, Storvik, SMC^2), not the engine",
    "pmcmc": "particle MCMC (pfcourse.pmmh, pfcourse.correlated, pfcourse.csmc), its filters built inside",
}


#: Every stored study, by name.  A group (``robot_studies``) is the studies named ``group/...``.

def _intel_cure_fields(steps: int) -> dict:
    """The provenance fields the intel studies of the cure share (map half, settings, lock-on rule)."""
    return {"map": "scans 455-909 of book/data/intel/intel-corrected.log.gz; runs on scans 0-454",
            "steps": steps, "settings": dataclasses.asdict(intel.GLOBAL_SETTINGS),
            "no_injection": "settings with inject_share = 0",
            "guarded_settings": dataclasses.asdict(intel.GUARDED_SETTINGS),
            "lock_on": "within 1 m and 3 x the odometry's RMS heading error "
                       f"of a step, at {intel.LOCK_SHARE} of the last {intel.LOCK_WINDOW} scans"}


def _map_global_drives(n_runs: int, base_seed: int, drives: str, entries: list) -> list[Study]:
    """map_global's paired studies on one set of drives (``drives``, e.g. "held-out drives 150-249"): one
    Study per ``(name, row, columns)``, each global drive and kidnapping seeded as maprobot/global and
    maprobot/kidnap, its filter by ``default_rng([41, s, 2])``."""
    return [Study(name=f"map_global/{name}", row=row, grid={}, n_runs=n_runs, seeds="run",
                  base_seed=base_seed, failures="raise", table=f"map_global/{name}.csv",
                  provenance=f"map_global/{name}.json", columns=columns, sample=1,
                  row_code=f"pfcourse/studies/map_global.py ({row.__name__}), pfcourse/scenarios/maprobot/global_mcl.py",
                  fields={"seeds": f"run s ({drives}): drive and scans as maprobot/global and maprobot/kidnap "
                                   "(data_rng(s, 0), kidnap_rng(s)); filter numpy.random.default_rng([41, s, 2])",
                          "dt": maprobot.DT, "heading_tolerance_rad": map_global.HEADING_TOL,
                          "lost": "pfcourse/studies/map_global.py lost_times: 2 s or more outside the lock-on "
                                  "tolerances, 2 m away at some step, after 10 s within them"})
            for name, row, columns in entries]

STUDIES: dict[str, Study] = {study.name: study for study in [
    Study(name="sir_fixes", row=sir_fixes_study.row,
          grid={"variant": sir_fixes_study.VARIANTS, "N": sir_fixes_study.N_VALUES}, n_runs=100, seeds="run",
          failures="raise", table="sir_fixes.csv", provenance="sir_fixes.json",
          columns=("variant", "N", "seed", "error", "coverage"), cheap=lambda t: t["N"] <= 300, sample=4,
          row_code="pfcourse/studies/sir_fixes_study.py (row)", filters=sir_fixes_study.FILTERS,
          fields={"seeds": "run s: simulation seed s, filter seed s + 10**6 (study_filter_seed)",
                  "landmark_noise": sir_fixes_study.LANDMARK_NOISE}),
    Study(name="rao_blackwell", row=rb_study.row,
          grid=tuple(g for scenario, n_values in rb_study.N_VALUES.items()
                     for g in ({"scenario": [scenario], "method": ["kalman"], "N": [0]},
                               {"scenario": [scenario], "method": list(rb_study.METHODS), "N": n_values})),
          n_runs=100, seeds="run", failures="raise", table="rao_blackwell.csv", provenance="rao_blackwell.json",
          columns=rb_study.COLUMNS, order=("scenario", "run"), volatile=("seconds", "seconds_per_step"),
          cheap=lambda t: (t["method"] != "kalman") & (t["N"] <= 300), sample=3,
          row_code="pfcourse/studies/rb_study.py (row), pfcourse/scenarios/landmarks/rao_blackwell.py, pfcourse/proposals.py",
          filters=rb_study.FILTERS,
          fields={"methods": rb_study.METHODS,
                  "seeds": "simulation seed s, filter seed s + 10**6 (same for every method and N)"}),
    Study(name="proposals", row=part1_studies.proposals_row,
          grid={"setting": part1_studies.SETTINGS, "proposal": part1_studies.PROPOSALS}, n_runs=50, seeds="run",
          failures="raise", table="proposals.csv", provenance="proposals.json",
          columns=("setting", "proposal", "seed", "ess", "ess_sum", "n_measured", "resampled", "robot",
                   "landmarks", "rmse"), sample=4, row_code="pfcourse/studies/part1_studies.py (proposals_row)",
          filters=part1_studies.FILTERS,
          fields={"seeds": "simulation seed s = 0-49, filter seed s + 10**6 (same for both proposals)",
                  "sharp_broad": "filters sweep/...; process noise 0.05^2 m^2 on every coordinate, measurement sd "
                                 "0.1 and 1 times the lab's"}),
    Study(name="rb_five_landmarks", row=part1_studies.five_landmarks_row,
          grid={"method": part1_studies.FIVE_METHODS}, n_runs=100, seeds="run", failures="raise",
          table="rb_five_landmarks.csv", provenance="rb_five_landmarks.json",
          columns=("method", "seed", "collapse", "lm_sd", "robot_sd", "robot_cover"), sample=4,
          row_code="pfcourse/studies/part1_studies.py (five_landmarks_row)", filters=part1_studies.FIVE_FILTERS,
          fields={"seeds": "simulation seed s = 0-99, filter seed s + 10**6 (same for every method)"}),
    # why_it_works and why_it_works_clt: seeds "run" (0, 1, ...), small enough to survive a row of floats
    Study(name="why_it_works", row=why_it_works.row, grid=why_it_works.GRID, n_runs=why_it_works.N_RUNS,
          seeds="run", failures="raise", table="why_it_works.csv", provenance="why_it_works.json", columns=why_it_works.COLUMNS,
          cheap=lambda t: (t["T"] <= 50) & (t["N"] <= 1000), sample=3,
          row_code="pfcourse/studies/why_it_works.py (row)", filters={"bootstrap": why_it_works.BOOTSTRAP},
          fields={"data": f"drifting landmark scenario, simulation seed {why_it_works.DATA_SEED}, "
                          f"{why_it_works.T_MAX + 1} samples",
                  "seeds": "filter seed r = 0, 1, ..., the same for every setting"}),
    Study(name="why_it_works_growth", row=why_it_works.growth_row,
          grid={"N": [why_it_works.GROWTH_N], "filter_run": why_it_works.GROWTH_FILTER_RUNS},
          n_runs=why_it_works.GROWTH_DATASETS, seeds="run", failures="raise", table="why_it_works_growth.csv",
          provenance="why_it_works_growth.json", columns=why_it_works.GROWTH_COLUMNS, sample=2,
          row_code="pfcourse/studies/why_it_works.py (growth_row)",
          filters={"bootstrap": why_it_works.EVERY_STEP},
          fields={"data": f"drifting landmark scenario, {why_it_works.T_MAX + 1} samples, simulation seed s = 0-99",
                  "seeds": "filter: generator filter_rng(s, filter_run)"}),
    Study(name="why_it_works_clt", row=why_it_works.clt_row, grid={"N": why_it_works.CLT_N_VALUES},
          n_runs=why_it_works.CLT_RUNS, seeds="run", failures="raise", table="why_it_works_clt.csv",
          provenance="why_it_works_clt.json", columns=("N", "seed", "error_last", "error_middle", "log_ratio"),
          cheap=lambda t: t["N"] <= 1000, sample=3, row_code="pfcourse/studies/why_it_works.py (clt_row)",
          fields={"data": f"scalar model x_k = 0.9 x_(k-1) + w_k, z_k = x_k + v_k, Q = R = 0.5, "
                          f"{why_it_works.CLT_STEPS + 1} samples, data_rng({why_it_works.DATA_SEED}, 0)",
                  "seeds": "filter seed r = 0, 1, ..."}, filters={"bootstrap": why_it_works.EVERY_STEP}),
    Study(name="why_it_works_resampling", row=why_it_works.resampling_row,
          grid={"resampling": why_it_works.RESAMPLING_SCHEMES}, n_runs=why_it_works.RESAMPLING_RUNS, seeds="run",
          failures="raise", table="why_it_works_resampling.csv", provenance="why_it_works_resampling.json",
          columns=("resampling", "seed", "error_last", "log_ratio"), sample=3,
          row_code="pfcourse/studies/why_it_works.py (resampling_row)",
          fields={"data": f"the scalar data of why_it_works_clt, data_rng({why_it_works.DATA_SEED}, 0)",
                  "seeds": "filter seed r = 0, 1, ..., the same for both schemes",
                  "engine": "the row is the bootstrap filter in plain NumPy (ten times faster on one dimension): "
                            "the engine's filters below, step for step"},
          filters={scheme: why_it_works.EVERY_STEP.with_(n_particles=why_it_works.RESAMPLING_N, resampler=scheme)
                   for scheme in why_it_works.RESAMPLING_SCHEMES}),
    *(_robot_study(name, grid, options) for name, (grid, options) in robot_studies.STUDIES.items()),
    Study(name="count_resampling", row=count_resampling.row, grid=count_resampling.GRID,
          n_runs=count_resampling.N_RUNS, seeds="run", failures="raise", table="count_resampling.csv",
          provenance="count_resampling.json", columns=("scheme", "tau", "seed", "rmse", "resamples"), sample=4,
          row_code="pfcourse/studies/count_resampling.py (row)",
          fields={"model": "Part III capstone's counts: phi 0.95, sigma 0.3, mu 1, 50 counts from default_rng(2027)",
                  "exact": "filtering means on a 1601-point grid (count_resampling.exact_means)",
                  "filter": f"bootstrap, N = {count_resampling.N_PARTICLES}, resample when ESS < tau N",
                  "seeds": "run r: numpy.random.default_rng(r), the same for every scheme and tau"}),
    Study(name="linear_n", row=count_resampling.linear_row, grid=count_resampling.LINEAR_GRID,
          n_runs=count_resampling.LINEAR_RUNS, seeds="run", failures="raise", table="linear_n.csv",
          provenance="linear_n.json", columns=("landmark_noise", "n_particles", "seed", "robot_gap", "landmark_gap"),
          cheap=lambda t: t["n_particles"] <= 100, sample=3,
          row_code="pfcourse/studies/count_resampling.py (linear_row)", filters={"bootstrap": count_resampling.LINEAR_FILTER},
          fields={"model": "Part I's two-landmark linear model (quadrant_scenario), 50 steps; landmark_noise: "
                           "process-noise variance of each landmark coordinate in the simulator and the filter",
                  "exact": "Kalman filter means",
                  "seeds": "run r: simulate(scenario, r), filter stream pfcourse.seeding.filter_rng(0, r), every N"}),
    *(_likelihood_study(name, row, {"n_particles": n}, runs, seed, columns=("n_particles", "run", "seed", "status", "error_message", *metrics), **options)
      for name, row, n, runs, seed, metrics, options in [
          ("bias", ls.bias_run, ls.N_BIAS, ls.N_BIAS_RUNS, ls.BIAS_SEED, ["log_ratio"], {"sample": 3}),
          ("ml", ls.ml_run, ls.N_ML, ls.N_ML_DATASETS, ls.ML_SEED,
           ["theta_kalman", "theta_pf", "nfev_kalman", "nfev_pf"], {}),
          ("smoothing_robot", ls.robot_gap_run, [ls.N_ROBOT_GAP], ls.ROBOT_GAP_RUNS, ls.ROBOT_GAP_SEED,
           ["filter_gap_error", "smoother_gap_error", "filter_outside_error", "smoother_outside_error",
            "smoother_gap_ess_median"], {"sample": 1}),
      ]),
    # one chain per row (a chain is one dependent sequence: the test re-computes the start of one,
    # tests/test_likelihood_data.py)
    _likelihood_study("pmmh", ls.pmmh_row, {"n_particles": ls.N_PMMH, "iterations": [ls.PMMH_ITERATIONS]}, 1,
                      ls.PMMH_SEED, seeds="run", columns=("n_particles", "iterations", "run", "seed", "theta",
                                                          "log_likelihood", "accepted"),
                      arrays=("theta", "log_likelihood", "accepted"), sample=0),
    _likelihood_study("terrain_rf", ls.terrain_rf_run,
                      {"flight": list(range(ls.N_TERRAIN_FLIGHTS)), "n_particles": [ls.N_TERRAIN]}, 1, 0,
                      columns=("flight", "n_particles", "run", "seed", "status", "error_message", "rf_scale_ml", "nfev",
                               "log_lik_ml", "log_lik_truth"), sample=1),
    _mcl_study("anatomy", global_localization.anatomy_row, {"n": global_localization.ANATOMY_N}, sample=3),
    *(_mcl_study(name, row, tuple({"method": [m], "n": [n]} for m, n in pairs), **options)
      for name, row, pairs, options in [
          ("lockon", global_localization.lockon_row, global_localization.LOCKON,
           {"sample": 4, "cheap": lambda t: (t["n"] <= 10000) | (t["method"] != "bootstrap"),  # 30 000: seconds
            **_GLOBAL_RUNS}),
          ("kidnap", global_localization.kidnap_row, global_localization.KIDNAP, {"sample": 3})]),
    _mcl_study("modes", global_localization.mode_run, {"method": list(global_localization.MODES)},
               arrays=("mass_near_truth", "ess_fraction"), sample=2),
    _mcl_study("ekf_vs_pf", global_localization.ekf_row, {"setting": list(global_localization.EKF_SETTINGS)},
               volatile=("pf_seconds", "ekf_seconds"), fields={"ekf_settings": global_localization.EKF_SETTINGS}),
    Study(name="terrain_remedies", row=terrain_remedies.row, grid={"setting": terrain_remedies.STORED_SETTINGS},
          n_runs=100, seeds="run", table="terrain_remedies.csv", **_FLIGHTS, provenance="terrain_remedies.json",
          columns=terrain_remedies.COLUMNS, seed_column="flight", cheap=lambda t: t["N"] <= 10000, sample=4,
          row_code="pfcourse/studies/terrain_remedies.py (run_one)",
          filters=terrain_remedies.FILTERS,
          fields={
                  "seeds": "flight r: pfcourse.seeding.data_rng(0, r); filter: pfcourse.seeding.filter_rng(0, r)",
                  "divergence": "final horizontal error > 500 m or every particle lost"}),
    Study(name="terrain_reference", row=terrain_remedies.reference_row,
          grid={"N": terrain_remedies.REFERENCE_SIZES, "repeat": terrain_remedies.REFERENCE_REPEATS},
          n_runs=5, seeds="run", failures="raise", table="terrain_reference.csv", provenance="terrain_reference.json",
          columns=terrain_remedies.REFERENCE_COLUMNS, order=("run",), seed_column="flight", cheap=lambda t: t["N"] == t["N"].min(), sample=1,  # about 10 s a row
          row_code="pfcourse/studies/terrain_remedies.py (reference_row)",
          filters={"bootstrap": terrain_remedies.REFERENCE_FILTER},
          fields={"seeds": "flight r: pfcourse.seeding.data_rng(0, r); filter: pfcourse.seeding.reference_rng(0, r, repeat)"}),
    Study(name="terrain_studies", row=terrain_studies.row,
          grid=tuple({"study": [study], "setting": list(group)} for study, group in terrain_studies.STUDIES.items()),
          n_runs=100, seeds="run", table="terrain_studies.csv", **_FLIGHTS, provenance="terrain_studies.json",
          columns=terrain_studies.COLUMNS, seed_column="flight",
          cheap=lambda t: t["setting"] != "every 0.1 s, dt = 0.1 s", sample=3,  # the 10 Hz runs take seconds each
          row_code="pfcourse/studies/terrain_studies.py (study_row)",
          filters={f"{study}/{setting}": terrain_studies.filter_settings(terrain_studies.configure(study, setting)[1])
                   for study, setting in terrain_studies.settings()},
          fields={"studies": terrain_studies.STUDIES,
                  "seeds": "flight r: pfcourse.seeding.data_rng(0, r); filter: pfcourse.seeding.filter_rng(0, r)",
                  "divergence": "final horizontal error > 500 m or every particle lost"}),
    Study(name="global_localization/kld_amcl", row=global_localization.kld_amcl_row,
          grid={"setting": list(global_localization.KLD_SETTINGS)}, n_runs=100, seeds="run", **_GLOBAL_RUNS,
          table="global_localization/kld_amcl.csv", provenance="global_localization/kld_amcl.json",
          columns=global_localization.COLUMNS["kld_amcl"], sample=2,
          row_code="pfcourse/studies/global_localization.py (kld_amcl_row)",
          filters=global_localization.KLD_SETTINGS),
    Study(name="global_localization/tracking_cost", row=global_localization.tracking_row,
          grid=tuple({"method": [m], "n": [n]} for m, n in global_localization.TRACKING), n_runs=100,
          seeds="run", failures="raise", table="global_localization/tracking_cost.csv",
          provenance="global_localization/tracking_cost.json", columns=global_localization.COLUMNS["tracking_cost"],
          sample=3,
          row_code="pfcourse/studies/global_localization.py (tracking_row)",
          filters=robot_mcl.FILTERS),
    Study(name="data_association", row=association.row, grid={"clutter_rate": list(association.CLUTTER_RATES)},
          n_runs=association.N_RUNS, seeds="run", failures="raise", table="data_association.csv",
          provenance="data_association.json",
          columns=("clutter_rate", "seed", "pf_rmse_m", "ekf_rmse_m", "ekf_wrong", "clutter", "pf_seconds",
                   "ekf_seconds"),
          volatile=("pf_seconds", "ekf_seconds"), sample=3,
          row_code="pfcourse/studies/association.py (row), pfcourse/scenarios/robot/association.py",
          filters={"bootstrap": association.FILTER},
          fields={"scenario": association.SCENARIO, "p_detect": association.P_DETECT,
                  "max_range_m": association.MAX_RANGE,
                  "seeds": "run r: robot and readings from pfcourse.seeding.data_rng(0, r); "
                           "particle filter: pfcourse.seeding.filter_rng(0, r)"}),
    Study(name="data_association_pdaf", row=association.pdaf_row,
          grid={"clutter_rate": list(association.CLUTTER_RATES)}, n_runs=association.N_RUNS, seeds="run",
          failures="raise", table="data_association_pdaf.csv", provenance="data_association_pdaf.json",
          columns=("clutter_rate", "seed", "pdaf_rmse_m", "pdaf_nees_mean", "pdaf_seconds"),
          volatile=("pdaf_seconds",), sample=3,
          row_code="pfcourse/studies/association.py (pdaf_row), pfcourse/scenarios/robot/association.py (run_pdaf)",
          fields={"scenario": association.SCENARIO, "p_detect": association.P_DETECT,
                  "max_range_m": association.MAX_RANGE, "gate_probability": 0.99,
                  "seeds": "run r: robot and readings from pfcourse.seeding.data_rng(0, r), as data_association"}),
    Study(name="data_association_nn", row=association.nn_row,
          grid={"clutter_rate": list(association.CLUTTER_RATES)}, n_runs=association.N_RUNS, seeds="run",
          failures="raise", table="data_association_nn.csv", provenance="data_association_nn.json",
          columns=("clutter_rate", "seed", "nn_rmse_m", "nn_wrong", "sequential_multi_steps", "nn_seconds"),
          volatile=("nn_seconds",), sample=3,
          row_code="pfcourse/studies/association.py (nn_row), pfcourse/scenarios/robot/association.py (run_nn_ekf)",
          fields={"scenario": association.SCENARIO, "p_detect": association.P_DETECT,
                  "max_range_m": association.MAX_RANGE, "gate_probability": 0.99,
                  "rule": "nearest-neighbour standard filter: the single gated (reading, landmark) pair of "
                          "smallest Mahalanobis distance, one update a step (Bar-Shalom, Daum and Huang 2009)",
                  "seeds": "run r: robot and readings from pfcourse.seeding.data_rng(0, r), as data_association"}),
    Study(name="robot/dead_reckoning", row=robot_experiments.dead_reckoning_row, grid={}, n_runs=100, seeds="run",
          failures="raise", table="robot/dead_reckoning.csv", provenance="robot/dead_reckoning.json",
          columns=("seed", "dr_final_m", "pf_final_m", "pf_max_m"), sample=1,
          row_code="pfcourse/studies/robot.py (dead_reckoning_row)",
          filters={"bootstrap": robot_experiments.DEAD_RECKONING_FILTER},
          fields={"seeds": "run s: simulate_robot(rng=s), filter run_filter_seed(s)"}),
    Study(name="robot_consistency_fixes", row=comparison.consistency_fix_row,
          grid={"setting": list(comparison.CONSISTENCY_FIXES)}, n_runs=100, seeds="run", failures="raise",
          table="robot_consistency_fixes.csv", provenance="robot_consistency_fixes.json",
          columns=("setting", "seed", "rmse_m", "nees_mean", "nees"), arrays=("nees",), sample=2,
          row_code="pfcourse/studies/comparison.py (consistency_fix_row)", filters=comparison.CONSISTENCY_FILTERS,
          fields={"scenario": f"robot_tracks' robot, {comparison.CONSISTENCY_STEPS} steps, true noise levels "
                              "in the data; burn-in " + str(comparison.CONSISTENCY_BURN_IN) + " steps",
                  "q_scale": {k: v[1] for k, v in comparison.CONSISTENCY_FIXES.items()},
                  "seeds": "run s: robot simulate_robot(None, s); filter pfcourse.seeding.filter_rng(0, s)"}),
    Study(name="terrain_map_error", row=terrain_remedies.map_error_row,
          grid={"setting": terrain_remedies.MAP_ERROR_SETTINGS},
          n_runs=50, seeds="run", table="terrain_map_error.csv", **_FLIGHTS, provenance="terrain_map_error.json",
          columns=terrain_remedies.MAP_ERROR_COLUMNS, seed_column="flight",
          cheap=lambda t: t["setting"] == "bootstrap N=3000", sample=2,  # the others take a second or more each
          row_code="pfcourse/studies/terrain_remedies.py (map_error_row)",
          filters=_terrain_filters(terrain_remedies.MAP_ERROR_SETTINGS),
          fields={"map": "filter's DEM: pfcourse.scenarios.terrain.map.mismatched_map(true DEM, map_error_rng(0, r)): "
                         "Gaussian smoothing of MAP_SMOOTHING_CELLS cells plus an error field of MAP_ERROR_SD m "
                         "correlated over MAP_ERROR_CORRELATION_CELLS cells",
                  "seeds": "flight r: pfcourse.seeding.data_rng(0, r); filter: pfcourse.seeding.filter_rng(0, r); "
                           "map error: pfcourse.seeding.map_error_rng(0, r)",
                  "divergence": "final horizontal error > 500 m or every particle lost"}),
    Study(name="terrain_error_paths", row=terrain_remedies.error_path_row,
          grid={"setting": terrain_remedies.ERROR_PATH_SETTINGS},
          n_runs=100, seeds="run", table="terrain_error_paths.csv", **{**_FLIGHTS, "failed_scores": terrain_remedies.LOST_PATH},
          provenance="terrain_error_paths.json", columns=terrain_remedies.ERROR_PATH_COLUMNS, seed_column="flight",
          arrays=("errors",), sample=2, row_code="pfcourse/studies/terrain_remedies.py (error_path_row)",
          filters=_terrain_filters(terrain_remedies.ERROR_PATH_SETTINGS),
          fields={"seeds": "flight r: pfcourse.seeding.data_rng(0, r); filter: pfcourse.seeding.filter_rng(0, r)",
                  "divergence": "final horizontal error > 500 m or every particle lost"}),
    Study(name="terrain_model_flights", row=terrain_remedies.model_flight_row,
          grid={"setting": terrain_remedies.MODEL_FLIGHT_SETTINGS}, n_runs=100, seeds="run",
          table="terrain_model_flights.csv", **{**_FLIGHTS, "failed_scores": terrain_remedies.LOST_MODEL_FLIGHT},
          provenance="terrain_model_flights.json", columns=terrain_remedies.MODEL_FLIGHT_COLUMNS, seed_column="flight",
          arrays=("errors",), sample=2, row_code="pfcourse/studies/terrain_remedies.py (model_flight_row)",
          filters=_terrain_filters(terrain_remedies.MODEL_FLIGHT_SETTINGS),
          fields={"seeds": "flight r: pfcourse.studies.terrain_remedies.model_flight(scenario, terrain, "
                           "pfcourse.seeding.data_rng(1, r)) (process noise Qf dt, readings N(0, Rf)); "
                           "filter: pfcourse.seeding.filter_rng(1, r)",
                  "divergence": "final horizontal error > 500 m or every particle lost"}),
    Study(name="terrain_equal_cost", row=terrain_remedies.equal_cost_row,
          grid={"setting": list(terrain_remedies.EQUAL_COST_FILTERS)}, n_runs=100, seeds="run",
          table="terrain_equal_cost.csv", **_FLIGHTS, provenance="terrain_equal_cost.json",
          columns=terrain_remedies.EQUAL_COST_COLUMNS, seed_column="flight", sample=4,
          row_code="pfcourse/studies/terrain_remedies.py (equal_cost_row)",
          filters=terrain_remedies.EQUAL_COST_FILTERS,
          fields={
                  "seeds": "flight r: pfcourse.seeding.data_rng(0, r); filter: pfcourse.seeding.filter_rng(0, r) "
                           "(the flights and filter seeds of terrain_remedies and terrain_mpf)",
                  "divergence": "final horizontal error > 500 m or every particle lost"}),
    *(Study(name=f"maprobot/{name}", row=row, grid=grid, n_runs=20 if name == "sensor_cost" else 100, seeds="run",
            failures="raise", volatile=("seconds", "field_seconds", "beam_seconds"),
            table=f"maprobot/{name}.csv", provenance=f"maprobot/{name}.json", columns=columns, sample=1,
            row_code=f"pfcourse/studies/maprobot.py ({row.__name__}), pfcourse/scenarios/maprobot/drive.py",
            fields={"seeds": "run s: drive and scans pfcourse.seeding.data_rng(s, 0); filter filter_rng(s, 0); "
                             "kidnapping kidnap_rng(s)", "dt": maprobot.DT}, filters=maprobot.FILTERS)
      for name, row, grid, columns in [
          ("tracking", maprobot.tracking_row, {"n_particles": [maprobot.TRACKING_N], "weighting": list(maprobot.WEIGHTINGS)},
           ("weighting", "n_particles", "seed", "position_rmse", "heading_rmse", "locked_on",
            "locked_on_every_step_5deg", "max_window_heading_error", "mean_ess_share", "p10_ess_share")),
          ("amcl_global", maprobot.amcl_global_row, ({"weighting": list(maprobot.WEIGHTINGS), "method": ["injection"]},
                                                  {"weighting": ["product"], "method": ["bootstrap"]}),
           ("weighting", "method", "seed", "locked_on", "final_position_error", "mean_ess_share", "p10_ess_share")),
          ("sensor_cost", maprobot.sensor_cost_row, {},
           ("seed", "n_poses", "field_lookups", "beam_cells", "field_seconds", "beam_seconds")),
          ("kld_tracking", maprobot.kld_tracking_row, {},
           ("seed", "position_rmse", "locked_on", "mean_particles", "max_particles_after_start"))]),
    *(Study(name=f"map_global/{name}", row=row, grid={}, n_runs=100, seeds="run", failures="raise",
            table=f"map_global/{name}.csv", provenance=f"map_global/{name}.json", columns=columns, sample=1,
            row_code=f"pfcourse/studies/map_global.py ({row.__name__}), pfcourse/scenarios/maprobot/global_mcl.py",
            fields={"seeds": "run s: drive and scans as maprobot/global and maprobot/kidnap (data_rng(s, 0), "
                             "kidnap_rng(s)); filter numpy.random.default_rng([41, s, 2])",
                    "dt": maprobot.DT, "heading_tolerance_rad": map_global.HEADING_TOL,
                    "lock_on": "pfcourse.scenarios.maprobot.lock_on.locked_on: within 1 m and 3 sd of one step's odometry "
                               "heading noise at 80 % of the last 20 s"})
      for name, row, columns in [("twins", map_global.twin_row, map_global.TWIN_COLUMNS),
                                 ("global", map_global.global_row, map_global.GLOBAL_COLUMNS),
                                 ("kidnap", map_global.kidnap_row, map_global.KIDNAP_COLUMNS),
                                 # a variant of the cure (global_mcl.POOR_FIT) on the same drives, paired with the above
                                 ("global_poor_fit", map_global.poor_fit_global_row, map_global.GLOBAL_COLUMNS),
                                 ("kidnap_poor_fit", map_global.poor_fit_kidnap_row, map_global.KIDNAP_COLUMNS),
                                 # the cure with the kidnap model's prior (global_mcl.HAZARD), paired with the above
                                 ("global_hazard", map_global.hazard_global_row, map_global.GLOBAL_COLUMNS),
                                 ("kidnap_hazard", map_global.hazard_kidnap_row, map_global.KIDNAP_COLUMNS)]),
    # the bound judged by the lock-on rule: an exact filter over the truth and its twins, drives 0-149
    Study(name="map_global/exact_twins", row=map_global.exact_row, grid={}, n_runs=map_global.FRESH_SEED + map_global.FRESH_RUNS,
          seeds="run", failures="raise", table="map_global/exact_twins.csv", provenance="map_global/exact_twins.json",
          columns=map_global.EXACT_COLUMNS, sample=2,
          row_code="pfcourse/studies/map_global.py (exact_row), pfcourse/scenarios/maprobot/twins.py (exact_twin_estimate)",
          fields={"seeds": "run s: the global drive of maprobot/global (data_rng(s, 0)); no random numbers of its own",
                  "dt": maprobot.DT, "heading_tolerance_rad": map_global.HEADING_TOL}),
    # the same bound on the held-out drives 150-249
    Study(name="map_global/exact_heldout", row=map_global.exact_row, grid={}, n_runs=map_global.HELDOUT_RUNS,
          base_seed=map_global.HELDOUT_SEED, seeds="run", failures="raise", table="map_global/exact_heldout.csv",
          provenance="map_global/exact_heldout.json", columns=map_global.EXACT_COLUMNS, sample=2,
          row_code="pfcourse/studies/map_global.py (exact_row), pfcourse/scenarios/maprobot/twins.py (exact_twin_estimate)",
          fields={"seeds": "run s (held-out drives 150-249): the global drive of maprobot/global (data_rng(s, 0)); "
                           "no random numbers of its own",
                  "dt": maprobot.DT, "heading_tolerance_rad": map_global.HEADING_TOL}),
    # the kidnap runs' bound on the held-out runs 150-249: the truth, then an exact filter over its twins after the kidnap
    Study(name="map_global/exact_kidnap_heldout", row=map_global.exact_kidnap_row, grid={}, n_runs=map_global.HELDOUT_RUNS,
          base_seed=map_global.HELDOUT_SEED, seeds="run", failures="raise", table="map_global/exact_kidnap_heldout.csv",
          provenance="map_global/exact_kidnap_heldout.json", columns=map_global.EXACT_KIDNAP_COLUMNS, sample=2,
          row_code="pfcourse/studies/map_global.py (exact_kidnap_row), pfcourse/scenarios/maprobot/twins.py "
                   "(exact_twin_estimate)",
          fields={"seeds": "run s (held-out runs 150-249): the kidnap drive of maprobot/kidnap (data_rng(s, 0), "
                           "kidnap_rng(s)); no random numbers of its own",
                  "dt": maprobot.DT, "heading_tolerance_rad": map_global.HEADING_TOL}),
    # the cure (global_mcl.HAZARD) re-measured on fresh drives 100-149, not those it was chosen on
    *_map_global_drives(map_global.FRESH_RUNS, map_global.FRESH_SEED, "fresh drives 100-149", [
        ("global_fresh", map_global.hazard_global_fresh_row, map_global.GLOBAL_FRESH_COLUMNS),
        ("kidnap_fresh", map_global.hazard_kidnap_fresh_row, map_global.KIDNAP_FRESH_COLUMNS)]),
    # held-out drives 150-249: the cure before hysteresis (global_mcl.HAZARD) and the cure (global_mcl.CURE), paired
    *_map_global_drives(map_global.HELDOUT_RUNS, map_global.HELDOUT_SEED, "held-out drives 150-249", [
        ("global_heldout_hazard", map_global.heldout_hazard_global_row, map_global.GLOBAL_FRESH_COLUMNS),
        ("kidnap_heldout_hazard", map_global.heldout_hazard_kidnap_row, map_global.KIDNAP_FRESH_COLUMNS),
        # the cure (global_mcl.CURE: hysteresis, the belief's evidence with its strata)
        ("global_heldout", map_global.heldout_global_row, map_global.GLOBAL_FRESH_COLUMNS),
        ("kidnap_heldout", map_global.heldout_kidnap_row, map_global.KIDNAP_FRESH_COLUMNS)]),
    # issue 41: the challenger (global_mcl.CHALLENGER) screened on development drives 0-149 against the cure's false
    # relocalizations there (the cure recomputed on the same drives); no threshold kept within them, so it was not run
    # on new drives (map_global_challenger.SCREEN_PASSED)
    *[dataclasses.replace(st, row_code=f"pfcourse/studies/map_global_challenger.py ({st.row.__name__}), "
                           "pfcourse/studies/map_global.py, pfcourse/scenarios/maprobot/global_mcl.py",
                          fields={**st.fields, "protocol": mgc.PROTOCOL})
      for st in _map_global_drives(mgc.DEV_RUNS, mgc.DEV_SEED, "development drives 0-149", [
          ("global_dev_cure", mgc.dev_cure_global_row, map_global.GLOBAL_FRESH_COLUMNS),
          ("kidnap_dev_cure", mgc.dev_cure_kidnap_row, map_global.KIDNAP_FRESH_COLUMNS)])
      + [dataclasses.replace(st, grid={"swap_nats": list(mgc.SWAP_NATS)}, columns=("swap_nats", *st.columns))
         for st in _map_global_drives(mgc.DEV_RUNS, mgc.DEV_SEED, "development drives 0-149", [
             ("global_dev_challenger", mgc.challenger_global_row, map_global.GLOBAL_FRESH_COLUMNS),
             ("kidnap_dev_challenger", mgc.challenger_kidnap_row, map_global.KIDNAP_FRESH_COLUMNS)])]
      + [dataclasses.replace(st, grid={"swap_nats": list(mgc.SWAP_NATS_HIGH)}, columns=("swap_nats", *st.columns))
         for st in _map_global_drives(mgc.DEV_RUNS, mgc.DEV_SEED, "development drives 0-149", [
             ("global_dev_challenger_high", mgc.challenger_global_row, map_global.GLOBAL_FRESH_COLUMNS),
             ("kidnap_dev_challenger_high", mgc.challenger_kidnap_row, map_global.KIDNAP_FRESH_COLUMNS)])]],
    # issue 41: islands (global_mcl.ISLANDS) on development drives 0-149 against the cure, then judged once on new
    # drives 250-349 registered before any run there (map_global_islands.PROTOCOL)
    *[Study(name=f"map_global/{name}", row=row, grid=grid, n_runs=n_runs, seeds="run", base_seed=base, failures="raise",
            table=f"map_global/{name}.csv", provenance=f"map_global/{name}.json", columns=columns, sample=1,
            row_code=f"pfcourse/studies/map_global_islands.py ({row.__name__}), pfcourse/studies/map_global.py, "
                     "pfcourse/scenarios/maprobot/global_mcl.py",
            fields={"seeds": f"run s ({drives}): drive and scans as maprobot/global and maprobot/kidnap "
                             "(data_rng(s, 0), kidnap_rng(s)); filter numpy.random.default_rng([41, s, 2])",
                    "dt": maprobot.DT, "heading_tolerance_rad": map_global.HEADING_TOL, "protocol": mgi.PROTOCOL,
                    "lost": "pfcourse/studies/map_global.py lost_times; after the evidence decided: from the step "
                            "from which the twin margin stays above log 99"})
      for name, row, grid, n_runs, base, drives, columns in [
          ("global_dev_islands", mgi.islands_row, {"arm": list(mgi.DEV_ARMS)}, mgi.DEV_RUNS, mgi.DEV_SEED,
           "development drives 0-149", mgi.COLUMNS),
          ("global_heldout3", mgi.islands_row, {"arm": list(mgi.HELDOUT_ARMS)}, mgi.HELDOUT_RUNS, mgi.HELDOUT_SEED,
           "held-out drives 250-349", mgi.COLUMNS),
          ("kidnap_heldout3", mgi.cure_kidnap_row, {}, mgi.HELDOUT_RUNS, mgi.HELDOUT_SEED,
           "held-out drives 250-349", map_global.KIDNAP_FRESH_COLUMNS)]],
    *[Study(name=f"map_global/{name}", row=row, grid={}, n_runs=mgi.HELDOUT_RUNS, base_seed=mgi.HELDOUT_SEED,
            seeds="run", failures="raise", table=f"map_global/{name}.csv", provenance=f"map_global/{name}.json",
            columns=columns, sample=2,
            row_code=f"pfcourse/studies/map_global.py ({row.__name__}), pfcourse/scenarios/maprobot/twins.py "
                     "(exact_twin_estimate)",
            fields={"seeds": f"run s (held-out drives 250-349): the {what} of maprobot/{what.split()[0]} "
                             "(data_rng(s, 0), kidnap_rng(s)); no random numbers of its own",
                    "dt": maprobot.DT, "heading_tolerance_rad": map_global.HEADING_TOL})
      for name, row, columns, what in [
          ("exact_heldout3", map_global.exact_row, map_global.EXACT_COLUMNS, "global drive"),
          ("exact_kidnap_heldout3", map_global.exact_kidnap_row, map_global.EXACT_KIDNAP_COLUMNS, "kidnap drive")]],
    # equal cost: uniform injection at N = 5000 on the held-out drives 150-249, paired with global_heldout (the cure)
    Study(name="map_global/injection_heldout", row=map_global.heldout_injection_row, grid={},
          n_runs=map_global.HELDOUT_RUNS, base_seed=map_global.HELDOUT_SEED, seeds="run", failures="raise",
          table="map_global/injection_heldout.csv", provenance="map_global/injection_heldout.json",
          columns=map_global.INJECTION_COLUMNS, volatile=("seconds", "injection_cpu_s", "cure_cpu_s"), sample=1,
          row_code="pfcourse/studies/map_global.py (heldout_injection_row), pfcourse/scenarios/maprobot/drive.py "
                   "(run_filter, FILTERS['injection'])",
          fields={"seeds": "run s (held-out drives 150-249): drive as maprobot/global (data_rng(s, 0)); injection "
                           "filter pfcourse.seeding.filter_rng(s, 0); the cure (timed only) default_rng([41, s, 2])",
                  "n_particles": map_global.INJECTION_N, "dt": maprobot.DT,
                  "heading_tolerance_rad": map_global.HEADING_TOL,
                  "cpu": "time.process_time per filter, one process, OMP/MKL/OPENBLAS threads 1"}),
    Study(name="terrain_mpf", row=terrain_marginalised.row, grid={"N": terrain_marginalised.SIZES},
          n_runs=100, seeds="run", table="terrain_mpf.csv", **_FLIGHTS, provenance="terrain_mpf.json",
          columns=terrain_marginalised.COLUMNS, seed_column="flight", cheap=lambda t: t["N"] <= 3000, sample=2,
          row_code="pfcourse/studies/terrain_marginalised.py (run_mpf)", filters={"marginalised": terrain_marginalised.MPF},
          fields={                  "seeds": "flight r: pfcourse.seeding.data_rng(0, r); filter: pfcourse.seeding.filter_rng(0, r)",
                  "divergence": "final horizontal error > 500 m or every particle lost"}),
    Study(name="terrain_grid", row=terrain_marginalised.grid_row, grid={"cell": [c for c, _ in terrain_marginalised.CELLS]},
          n_runs=terrain_marginalised.GRID_FLIGHTS, seeds="run", failures="raise", table="terrain_grid.csv",
          provenance="terrain_grid.json", columns=terrain_marginalised.GRID_COLUMNS, seed_column="flight",
          cheap=lambda t: t["cell"] == t["cell"].max(), sample=1,  # about 2 s a row
          row_code="pfcourse/studies/terrain_marginalised.py (run_grid)",
          fields={"cells": terrain_marginalised.CELLS,
                  "seeds": "flight r: pfcourse.seeding.data_rng(0, r); the grid filter draws nothing",
                  "divergence": "final horizontal error > 500 m"}),
    Study(name="terrain_field", row=terrain_field.field_row, grid={"setting": terrain_field.FIELD_SETTINGS},
          n_runs=terrain_field.FIELD_FLIGHTS, seeds="run", failures="raise", table="terrain_field.csv",
          provenance="terrain_field.json", columns=terrain_field.FIELD_COLUMNS, seed_column="flight", sample=2,
          cheap=lambda t: t["setting"] != "grid 12.5 m",
          row_code="pfcourse/studies/terrain_field.py (field_row), pfcourse/scenarios/terrain/field.py",
          filters={name: terrain_field.FIELD_PF for name in terrain_field.FIELD_SETTINGS if not name.startswith("grid")},
          fields={"problem": "2-D: INS displacement known up to a drift of 3 m per axis per second, barometric "
                             "altitude known; readings h(p) + N(0, 20^2)", "settings": terrain_field.FIELD_SETTINGS,
                  "seeds": "flight r: pfcourse.seeding.data_rng(0, r); filter: pfcourse.seeding.filter_rng(0, r)"}),
    Study(name="terrain_field_pf", row=terrain_field.field_pf_row, grid={"setting": list(terrain_field.FIELD_PF_SETTINGS)},
          n_runs=terrain_field.FIELD_FLIGHTS, seeds="run", failures="raise", table="terrain_field_pf.csv",
          provenance="terrain_field_pf.json", columns=terrain_field.FIELD_COLUMNS, seed_column="flight", sample=2,
          row_code="pfcourse/studies/terrain_field.py (field_pf_row)", filters=terrain_field.FIELD_PF_FILTERS,
          fields={"problem": "the 2-D field problem of terrain_field, its flights and filter seeds "
                             "(data_rng(0, r), filter_rng(0, r))"}),
    Study(name="terrain_map_bias", row=terrain_field.map_bias_row, grid={"setting": terrain_field.MAP_BIAS_SETTINGS},
          n_runs=terrain_field.MAP_BIAS_FLIGHTS, seeds="run", table="terrain_map_bias.csv", **_FLIGHTS,
          provenance="terrain_map_bias.json", columns=terrain_field.MAP_BIAS_COLUMNS, seed_column="flight",
          cheap=lambda t: t["setting"].str.startswith("1 Hz"), sample=2,
          row_code="pfcourse/studies/terrain_field.py (map_bias_row), pfcourse/scenarios/terrain/map_bias.py",
          filters=terrain_field.MAP_BIAS_FILTERS,
          fields={"map": "filter's DEM: pfcourse.scenarios.terrain.map.mismatched_map(true DEM, map_error_rng(0, r)), "
                         "as terrain_map_error",
                  "seeds": "flight r: pfcourse.seeding.data_rng(0, r); filter: pfcourse.seeding.filter_rng(0, r)",
                  "divergence": "final horizontal error > 500 m or every particle lost"}),
    Study(name="terrain_costs", row=terrain_field.cost_row, grid={"timed": ["terrain decision"]},
          n_runs=terrain_field.COST_FLIGHTS, seeds="run", failures="raise", table="terrain_costs.csv",
          provenance="terrain_costs.json", columns=terrain_field.COST_COLUMNS, seed_column="flight", sample=1,
          volatile=("seconds", *terrain_field.COST_TIMES),
          row_code="pfcourse/studies/terrain_field.py (cost_row)",
          fields={"filters": {name: n for name, (_, n) in terrain_field.COST_FILTERS.items()},
                  "timing": "flight r: every filter in one process, a warm-up round then 2 rounds in an order "
                            "rotating with the round and the flight; CPU time (time.process_time) of the faster "
                            "round, s"}),
    Study(name="smoothing/landmarks", row=smoothing_studies.landmarks_row,
          grid={"n_particles": smoothing_studies.N_VALUES}, n_runs=smoothing_studies.N_RUNS, seeds="run",
          failures="raise", table="smoothing/landmarks.csv", provenance="smoothing/landmarks.json",
          cheap=lambda t: t["n_particles"] == t["n_particles"].min(), sample=1,
          row_code="pfcourse/studies/smoothing_studies.py (landmarks_row), pfcourse/smoothing.py",
          filters={"bootstrap": smoothing_studies.FILTER},
          fields={"lags": smoothing_studies.LAGS, "scenario": "quadrant_scenario().with_(Qw=0.05**2 I6, Rv=0.5**2 I4)",
                  "seeds": f"run r: data pfcourse.seeding.data_rng({smoothing_studies.SEED}, r); filter and FFBSi "
                           f"draws pfcourse.seeding.filter_rng({smoothing_studies.SEED}, r)"}),
    *(Study(name=f"static_parameters/{name}", row=row, grid=grid, n_runs=sps.N_RUNS, seeds="run", failures="raise",
            table=f"static_parameters/{name}.csv", provenance=f"static_parameters/{name}.json", columns=columns,
            cheap=cheap, sample=2, row_code=f"pfcourse/studies/static_parameters_study.py ({row.__name__}), "
                                            "pfcourse/static_parameters.py", fields={**sps.PROVENANCE, **more})
      for name, row, grid, columns, cheap, more in [
          ("main", sps.main_row, sps.MAIN_GRIDS, sps.MAIN_COLUMNS, lambda t: t["n"] == 1000, {}),
          ("long", sps.long_row, sps.LONG_GRIDS, sps.LONG_COLUMNS,
           lambda t: t["T"] == 50, {"N": sps.LONG_N, "long_data": f"{sps.LONG_K} steps, seed {sps.DATA_SEED}"}),
      ]),
    Study(name="static_parameters/long_big", row=sps.long_row, grid=sps.LONG_BIG_GRID, n_runs=sps.N_RUNS, seeds="run",
          failures="raise", table="static_parameters/long_big.csv", provenance="static_parameters/long_big.json",
          columns=sps.LONG_BIG_COLUMNS, sample=1,  # about 7 s a row
          row_code="pfcourse/studies/static_parameters_study.py (long_row), pfcourse/static_parameters.py",
          fields={**sps.PROVENANCE, "long_data": f"{sps.LONG_K} steps, seed {sps.DATA_SEED}",
                  "pairing": "run r has the seed of run r of static_parameters/long"}),
    Study(name="static_parameters/smc2", row=sps.main_row, grid=sps.SMC2_GRID, n_runs=sps.SMC2_RUNS, seeds="run",
          failures="raise", table="static_parameters/smc2.csv", provenance="static_parameters/smc2.json",
          columns=sps.MAIN_COLUMNS, sample=1,  # about 2 s a row
          row_code="pfcourse/studies/static_parameters_study.py (main_row), pfcourse/static_parameters.py",
          fields={**sps.PROVENANCE, "runs": "fewer than 100: SMC^2 is the expensive sampler"}),
    # one chain per row; a long chain takes minutes, so the test re-computes the short chains of the
    # "_check" study, whose seeds are the long ones' (tests/test_pmcmc.py: each is the start of its long chain)
    *(Study(name=f"pmcmc/{name}{suffix}", row=row, grid=grid, n_runs=pm.N_CHAINS, base_seed=pm.SEEDS[name],
            failures="raise", table=f"pmcmc/{name}{suffix}.csv", provenance=f"pmcmc/{name}.json", arrays=arrays,
            sample=0 if not suffix else 1, row_code=f"pfcourse/studies/pmcmc_studies.py ({row.__name__})",
            fields=pm.PROVENANCE_FIELDS[name])
      for name, row, key, values, length, check, arrays in (
          ("tuning", pm.tuning_row, "n_particles", pm.N_TUNING, pm.ITERATIONS, pm.N_TUNING[0], ("theta", "accepted")),
          ("correlated", pm.correlated_row, "rho", pm.RHOS, pm.ITERATIONS, pm.RHOS[-1], ("theta", "accepted")),
          ("pgas", pm.pgas_row, "ancestor_sampling", [True, False], pm.PGAS_SWEEPS, True, ("theta",)))
      for suffix, grid in (("", {key: values, "iterations": [length]}),
                           ("_check", {key: [check], "iterations": [pm.CHECK_ITERATIONS]}))),
    Study(name="pmcmc/pairs", row=pm.pair_row, grid={"rho": pm.PAIR_RHOS}, n_runs=pm.PAIR_RUNS, seeds="run",
          base_seed=pm.PAIR_SEED, failures="raise", table="pmcmc/pairs.csv", provenance="pmcmc/pairs.json", sample=1,
          row_code="pfcourse/studies/pmcmc_studies.py (pair_row), pfcourse/correlated.py",
          fields=pm.PROVENANCE_FIELDS["pairs"]),
    *(Study(name=name, row=row, grid={"method": list(methods)}, n_runs=intel.N_GLOBAL,
            seeds="run", failures="raise", table=f"{name}.csv", provenance=f"{name}.json",
            columns=columns, sample=1,
            row_code="pfcourse/studies/intel.py (global_row), pfcourse/scenarios/maprobot/global_mcl.py (global_mcl)",
            fields={"seeds": "run s: start scan numpy.random.default_rng([41, s]); filter default_rng([41, s, 1])",
                    "map": map_text, "steps": intel.GLOBAL_STEPS, "settings": dataclasses.asdict(settings),
                    "lock_on": "within 1 m and 3 x the odometry's RMS heading error "
                    f"of a step, at {intel.LOCK_SHARE} of the last {intel.LOCK_WINDOW} scans"})
      for name, row, methods, columns, settings, map_text in (
          ("intel/global", intel.global_row, intel.GLOBAL_METHODS, intel.GLOBAL_COLUMNS, intel.GLOBAL_SETTINGS,
           "scans 455-909 of book/data/intel/intel-corrected.log.gz (whole_map: scans 0-909); runs on scans 0-454"),
          ("intel/global_previous", partial(intel.global_row, settings=intel.PREVIOUS_SETTINGS), intel.GLOBAL_METHODS,
           intel.PREVIOUS_COLUMNS, intel.PREVIOUS_SETTINGS,
           "scans 455-909 of book/data/intel/intel-corrected.log.gz (whole_map: scans 0-909); runs on scans 0-454"),
          ("intel/map_control", intel.global_row, intel.CONTROL_METHODS, intel.GLOBAL_COLUMNS, intel.GLOBAL_SETTINGS,
           f"every scan of book/data/intel/intel-corrected.log.gz but the run's own and {intel.LEAVE_OUT_MARGIN} "
           "on each side (on the whole run's grid); runs on scans 0-454"),
          ("intel/guarded_maps", partial(intel.global_row, settings=intel.GUARDED_SETTINGS), intel.GUARDED_MAP_METHODS,
           intel.GLOBAL_COLUMNS, intel.GUARDED_SETTINGS,
           "whole_map: scans 0-909 of book/data/intel/intel-corrected.log.gz; drift_corrected: scans 455-909; "
           f"leave_out: every scan but the run's own and {intel.LEAVE_OUT_MARGIN} on each side; runs on scans 0-454"))),
    Study(name="intel/map_control_margin", row=intel.margin_row, grid={"margin": [intel.MARGIN_CHECK]},
          n_runs=intel.N_MARGIN_CHECK, seeds="run", failures="raise", table="intel/map_control_margin.csv",
          provenance="intel/map_control_margin.json", columns=("margin",) + intel.GLOBAL_COLUMNS, sample=1,
          row_code="pfcourse/studies/intel.py (margin_row, global_row), pfcourse/scenarios/maprobot/global_mcl.py",
          fields={"seeds": "run s: start scan numpy.random.default_rng([41, s]); filter default_rng([41, s, 1])",
                  "map": f"every scan of book/data/intel/intel-corrected.log.gz but the run's own and "
                  f"{intel.MARGIN_CHECK} on each side (on the whole run's grid); runs on scans 0-454",
                  "steps": intel.GLOBAL_STEPS, "settings": dataclasses.asdict(intel.GLOBAL_SETTINGS)}),
    Study(name="intel/injection", row=intel.injection_row, grid={"method": list(intel.INJECTION_METHODS)},
          n_runs=intel.N_GLOBAL, seeds="run", failures="raise", table="intel/injection.csv",
          provenance="intel/injection.json", columns=intel.INJECTION_COLUMNS, arrays=intel.INJECTION_ARRAYS, sample=1,
          volatile=("seconds", "cpu_seconds"),
          row_code="pfcourse/studies/intel.py (injection_row, global_row), pfcourse/scenarios/maprobot/global_mcl.py",
          fields={"seeds": "run s: start scan numpy.random.default_rng([41, s]); filter default_rng([41, s, 1])",
                  **_intel_cure_fields(intel.GLOBAL_STEPS)}),
    Study(name="intel/long_runs", row=intel.long_row, grid={"method": list(intel.LONG_METHODS)},
          n_runs=intel.N_GLOBAL, seeds="run", failures="raise", table="intel/long_runs.csv",
          provenance="intel/long_runs.json", columns=intel.GLOBAL_COLUMNS, sample=1,
          row_code="pfcourse/studies/intel.py (long_row, global_row), pfcourse/scenarios/maprobot/global_mcl.py",
          fields={"seeds": "run s: start scan numpy.random.default_rng([41, s]) in 0-374; filter default_rng([41, s, 1])",
                  **_intel_cure_fields(intel.LONG_STEPS)}),
    Study(name="intel/islands", row=intel.islands_row, grid={"steps": list(intel.ISLANDS_STEPS)},
          n_runs=intel.N_GLOBAL, seeds="run", failures="raise", table="intel/islands.csv",
          provenance="intel/islands.json", columns=intel.ISLANDS_COLUMNS, sample=1,
          row_code="pfcourse/studies/intel.py (islands_row, global_row), pfcourse/scenarios/maprobot/global_mcl.py",
          fields={"seeds": "run s: start scan numpy.random.default_rng([41, s]) in 0-(454 - steps); "
                           "filter default_rng([41, s, 1]) (the runs of intel/injection and intel/long_runs)",
                  "map": "scans 455-909 of book/data/intel/intel-corrected.log.gz; runs on scans 0-454",
                  "steps": list(intel.ISLANDS_STEPS), "islands_settings": dataclasses.asdict(intel.ISLANDS_SETTINGS),
                  "protocol": "the islands (global_mcl.ISLANDS: 4 islands of 200 poses, margin log 99) were fixed on "
                              "chapter 15's development drives 0-149 (map_global/global_dev_islands) and are judged "
                              "here once, unchanged; each run is paired with the guarded cure's run of the same seed "
                              "and length (intel/injection at 40 scans, intel/long_runs at 80)",
                  "lock_on": "within 1 m and 3 x the odometry's RMS heading error "
                             f"of a step, at {intel.LOCK_SHARE} of the last {intel.LOCK_WINDOW} scans"}),
    Study(name="intel/islands_map_control", row=intel.islands_control_row, grid={}, n_runs=intel.N_GLOBAL, seeds="run",
          failures="raise", table="intel/islands_map_control.csv", provenance="intel/islands_map_control.json",
          columns=intel.GLOBAL_COLUMNS, sample=1,
          row_code="pfcourse/studies/intel.py (islands_control_row, global_row), pfcourse/scenarios/maprobot/global_mcl.py",
          fields={"seeds": "run s: start scan numpy.random.default_rng([41, s]); filter default_rng([41, s, 1]) "
                           "(the runs of intel/guarded_maps, arm leave_out)",
                  "map": f"every scan of book/data/intel/intel-corrected.log.gz but the run's own and "
                  f"{intel.LEAVE_OUT_MARGIN} on each side (on the whole run's grid); runs on scans 0-454",
                  "steps": intel.GLOBAL_STEPS, "islands_settings": dataclasses.asdict(intel.ISLANDS_SETTINGS),
                  "protocol": "the islands (global_mcl.ISLANDS) were fixed on chapter 15's development drives 0-149 "
                              "and are judged here once, unchanged, on the map control",
                  "lock_on": "within 1 m and 3 x the odometry's RMS heading error "
                             f"of a step, at {intel.LOCK_SHARE} of the last {intel.LOCK_WINDOW} scans"}),
    Study(name="intel/cluster_estimate", row=intel_clusters.cluster_row, grid={}, n_runs=intel.N_GLOBAL, seeds="run",
          failures="raise", table="intel/cluster_estimate.csv", provenance="intel/cluster_estimate.json",
          columns=intel_clusters.CLUSTER_COLUMNS, sample=1,
          row_code="pfcourse/studies/intel_clusters.py (cluster_row), pfcourse/scenarios/maprobot/global_mcl.py",
          fields={"seeds": "run s: start scan numpy.random.default_rng([41, s]); filter default_rng([41, s, 1])",
                  "map": "scans 455-909 of book/data/intel/intel-corrected.log.gz; runs on scans 0-454",
                  "steps": intel.GLOBAL_STEPS, "settings": dataclasses.asdict(intel.GUARDED_SETTINGS),
                  "cluster": f"cells {intel_clusters.CLUSTER_BIN} (m, m, rad), the heaviest cell, then the particles "
                  f"within {intel_clusters.CLUSTER_RADIUS} m of its mean"}),
    Study(name="intel/tracking", row=intel.tracking_row, grid={"map": list(intel.TRACK_MAPS)},
          n_runs=len(intel.TRACK_SEEDS), seeds="run", base_seed=intel.TRACK_SEEDS.start, failures="raise",
          table="intel/tracking.csv", provenance="intel/tracking.json", columns=intel.TRACK_COLUMNS, sample=1,
          arrays=intel.TRACK_ARRAYS, filters={"tracking": intel.TRACK_FILTER},
          row_code="pfcourse/studies/intel.py (tracking_row)",
          fields={"seeds": "run s: filter numpy.random.default_rng(s), s = 1..30 (the chapter's run is s = 1)",
                  "maps": "second half: scans 455-909; whole run: scans 0-909; tracked: scans 0-454",
                  "model": f"odometry a = {intel.TRACK_A}, every {intel.BEAM_STEP}th beam"}),
    *(Study(name=name, row=partial(terrain_remedies.fresh_flight_row, study=name), grid={"setting": list(fresh.settings)},
            n_runs=len(fresh.flights), seeds="run", base_seed=fresh.flights.start,
            table=f"{name}.csv", **_FLIGHTS, provenance=f"{name}.json", columns=terrain_remedies.FRESH_COLUMNS, seed_column="flight",
            sample=2, row_code="pfcourse/studies/terrain_remedies.py (fresh_flight_row)",
            filters={label: terrain_remedies.FILTERS[name] for label, name in fresh.settings.items()},
            fields={"flights": [fresh.flights.start, fresh.flights.stop - 1], "criterion": fresh.criterion,
                    "settings": fresh.settings,
                    "seeds": "flight r: pfcourse.seeding.data_rng(0, r); filter: pfcourse.seeding.filter_rng(0, r)",
                    "divergence": "final horizontal error > 500 m or every particle lost"})
      for name, fresh in terrain_remedies.FRESH_FLIGHTS.items()),
]}


def robot_study(grid: dict, **options) -> pd.DataFrame:
    """The stored robot study (``robot_studies/NAME``) with exactly this grid and these ``pf_run``
    options (besides :data:`~pfcourse.studies.robot_studies.DEFAULTS`), read by its
    :meth:`Study.load`.

    Lets a chapter state each study as it would run it, ``robot_study({"r_scale": [...]})``; a grid
    or options that no stored study has are refused with a :class:`~pfcourse.errors.ParameterError`
    (run them with ``run_study`` instead), so the chapter cannot drift from the data.
    """
    for name, (stored_grid, stored_options) in robot_studies.STUDIES.items():
        if stored_grid == grid and stored_options == options:
            return STUDIES[f"robot_studies/{name}"].load()
    raise ParameterError(f"no stored robot study has grid {grid} and options {options}; "
                         f"stored: {list(robot_studies.STUDIES)} (pfcourse.studies.robot_studies.STUDIES)")


#: The stored cross-checks against Chopin and Papaspiliopoulos' ``particles`` library: one record
#: each (the other library's numbers and how they were made), written by the named code, not studies.
CROSS_CHECKS: dict[str, tuple[str, str]] = {
    "why_it_works": ("why_it_works_particles.json", "pfcourse/studies/why_it_works_particles.py"),
    "particle_mcmc": ("pmcmc/particles_check.json", "pfcourse/studies/pmcmc_crosscheck.py"),
    "static_parameters": ("static_parameters/particles_check.json", "tools/static_parameters_particles.py"),
}


def cross_check(chapter: str) -> dict:
    """The stored cross-check of ``chapter`` against ``particles`` (:data:`CROSS_CHECKS`), as a dict."""
    if chapter not in CROSS_CHECKS:
        raise ParameterError(f"no stored cross-check for {chapter!r}; stored: {list(CROSS_CHECKS)}")
    path, code = CROSS_CHECKS[chapter]
    if not (DATA / path).exists():
        raise FileNotFoundError(f"{DATA / path} is missing: run {code}")
    return json.loads((DATA / path).read_text())


def select(name: str) -> list[Study]:
    """The study ``name``, or every study of the group ``name``."""
    chosen = [STUDIES[name]] if name in STUDIES else [s for s in STUDIES.values() if s.name.startswith(name + "/")]
    if not chosen:
        groups = sorted({n.split("/")[0] for n in STUDIES})
        raise ParameterError(f"unknown study {name!r}; registered: {', '.join(groups)} "
                             f"(or one study of a group: {', '.join(n for n in STUDIES if '/' in n)})")
    return chosen


SEED_TEXT = {"replicate": "run r: pfcourse.seeding.replicate_seed({base}, r)", "run": "run r: seed {base} + r"}


def run(name: str, **options) -> None:
    """Compute and store the study (or group) ``name``, then its provenance record.

    A study alone in its provenance file has its fields at the top of the record; the studies of
    a group sharing one file are under ``studies``, with the fields they share (``n_runs``,
    ``seeds``) also at the top.  A re-run of some of the studies of such a group keeps the
    group's record and appends one entry per study to its ``reruns`` list.
    """
    studies = select(name)
    start, commit = time.time(), launch_commit()
    records = {}
    for study in studies:
        t0 = time.time()
        table = study.compute(**options)
        study.save(table)
        records[study.name] = {"file": Path(study.table).name, "row": getattr(study.row, "__name__", repr(study.row)),
                               "grid": study.grid, "n_runs": options.get("n_runs") or study.n_runs, "failures": study.failures,
                               "seeds": SEED_TEXT[study.seeds].format(base=study.base_seed),
                               "rows": len(table), "run_seconds": round(time.time() - t0, 1), **study.fields,
                               "filters": study.filter_records()}
        print(f"{study.name}: {len(table)} rows, {records[study.name]['run_seconds']} s", flush=True)
    for path in {study.provenance for study in studies}:
        sharing = [s for s in STUDIES.values() if s.provenance == path]
        if len(sharing) > 1 and (DATA / path).exists() and not all(s in studies for s in sharing):
            for s in studies:
                if s.provenance == path:
                    append_rerun(DATA / path, code="pfcourse/studies/registry.py", commit=commit,
                                 seconds=time.time() - start, study=s.name.split("/", 1)[-1], row_code=s.row_code,
                                 **records[s.name])
            continue
        group = [records[s.name] for s in studies if s.provenance == path]
        shared = {key: group[0][key] for key in ("n_runs", "seeds") if all(r[key] == group[0][key] for r in group)}
        fields = group[0] if len(group) == 1 else {**shared, "studies": {s.name: records[s.name] for s in studies
                                                                         if s.provenance == path},
                                                   "filters": {k: v for r in group for k, v in r["filters"].items()}}
        write_provenance(DATA / path, code="pfcourse/studies/registry.py", commit=commit,
                         seconds=time.time() - start, row_code=sorted({s.row_code for s in studies}),
                         seconds_column="wall time of one run on a shared 2-core machine: indicative only", **fields)


def extend(name: str, n_runs: int, **options) -> None:
    """Append runs ``len(stored) .. n_runs - 1`` of the study (or each study of the group) ``name`` to its stored
    table, computed by :meth:`Study.compute` (the same row code and seeds as a full run; each row depends only on
    its seed), and record both goes under the provenance's ``runs``.  Only a study alone in its provenance file and
    with one setting per run (``grid={}``) is extended; the stored rows must be its first runs, in order."""
    commit = launch_commit()
    for study in select(name):
        if sum(s.provenance == study.provenance for s in STUDIES.values()) > 1 or grid_settings(study.grid) != [{}]:
            raise ParameterError(f"study {study.name}: only a study with its own provenance file and no grid is extended")
        stored = study.load()
        first = len(stored)
        old_seeds = [SEED_RULES[study.seeds](study.base_seed, r) for r in range(first)]
        if list(stored[study.seed_column]) != old_seeds:
            raise ParameterError(f"study {study.name}: the stored rows are not its runs 0 .. {first - 1} in order")
        t0 = time.time()
        new = study.compute(n_runs, first=first, **options)
        table = pd.concat([stored, new[list(stored.columns)]], ignore_index=True)
        study.save(table)
        old = study.provenance_record()
        seed_of = SEED_RULES[study.seeds]
        goes = old.get("runs") or [{"commit": old["git_commit"], "working_tree_modified": old["working_tree_modified"],
                                    "date_utc": old["date_utc"], "wall_seconds": old["wall_seconds"],
                                    "runs": f"0-{first - 1}", "seeds": f"{seed_of(study.base_seed, 0)}-"
                                                                       f"{seed_of(study.base_seed, first - 1)}"}]
        go = {"commit": commit, "working_tree_modified": tree_modified(),
              "date_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
              "wall_seconds": round(time.time() - t0, 1), "runs": f"{first}-{n_runs - 1}",
              "seeds": f"{seed_of(study.base_seed, first)}-{seed_of(study.base_seed, n_runs - 1)}",
              "how": f"python3 tasks.py study {study.name} --extend {n_runs} (registry.extend: the rows of the "
                     "runs not stored, computed by Study.compute, appended)"}
        record = {key: value for key, value in old.items() if key not in ("git_commit", "working_tree_modified", "runs")}
        record.update(runs=[*goes, go], n_runs=n_runs, rows=len(table), filters=study.filter_records(),
                      python=platform.python_version(), numpy=np.__version__,
                      wall_seconds=round(sum(g["wall_seconds"] for g in [*goes, go]), 1),
                      run_seconds=round(sum(g["wall_seconds"] for g in [*goes, go]), 1), **study.fields)
        record.pop("date_utc", None)
        (DATA / study.provenance).write_text(json.dumps(record, indent=2, default=str) + "\n")
        print(f"{study.name}: {first} stored + {len(new)} new rows, {go['wall_seconds']} s", flush=True)


def main(argv: Sequence[str]) -> int:
    """``python3 tasks.py study NAME [--runs R | --extend R [--workers W]]`` (``--runs``: fewer runs per setting, for
    a trial; ``--extend``: append the runs not yet stored, :func:`extend`)."""
    parser = argparse.ArgumentParser(prog="python3 tasks.py study", description="Run and store a registered study.")
    parser.add_argument("name", help="a study or a group: " + ", ".join(sorted({n.split("/")[0] for n in STUDIES})))
    parser.add_argument("--runs", type=int, default=None, help="runs per setting (default: the study's own; the table is stored all the same)")
    parser.add_argument("--extend", type=int, default=None, metavar="R",
                        help="append runs len(stored) .. R-1 to the stored table (the study's own rows and seeds)")
    parser.add_argument("--workers", type=int, default=None, help="processes of the pool (default: the cores)")
    args = parser.parse_args(argv)
    try:
        if args.extend is not None:
            executor = SerialExecutor() if args.workers == 1 else None
            extend(args.name, args.extend, batch_size=1,
                   **({"executor": executor} if executor else {}))
            return 0
        run(args.name, n_runs=args.runs)
    except ParameterError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
