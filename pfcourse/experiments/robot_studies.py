"""Part III's robot studies: their settings, and their tables stored under ``book/data/robot_studies/``.

Each study runs :func:`pfcourse.experiments.robot.pf_run` over one grid, ``N_RUNS`` seeded
runs per setting (run ``r`` has seed ``replicate_seed(0, r)`` in every study: common random
numbers), through :func:`pfcourse.experiments.study.run_study`. Together they take about
50 s on two cores, a sixth of the book's execution budget, so ``tools/studies/robot_studies.py``
runs them once and stores each table (:func:`save`); the chapter reads them (:func:`load`),
and ``tests/test_robot_studies_data.py`` re-runs a seeded sample of rows and requires the
same numbers.

A table is stored as ``NAME.csv`` (one row per run: the setting, ``run``, ``seed``,
``status``, ``error`` and the scalar metrics, floats written to round-trip exactly) and, for
the studies that keep per-step errors, ``NAME.npz`` (one 2-D array per per-step column, one
row per table row; a failed run's row is NaN).
"""

from __future__ import annotations

import ast
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd

from pfcourse.errors import ParameterError
from pfcourse.experiments.robot import pf_run
from pfcourse.experiments.study import run_study

N_RUNS = 100
N_STEPS, BURN_IN = 100, 20
DEFAULTS = dict(n_steps=N_STEPS, burn_in=BURN_IN)
DATA = Path(__file__).resolve().parents[2] / "book" / "data" / "robot_studies"
GAP = (100.0, 200.0)

#: study name -> (grid, options of pf_run besides DEFAULTS)
STUDIES: dict[str, tuple[dict, dict]] = {
    "n_particles": ({"n_particles": [20, 50, 100, 300, 1000]}, {}),
    "q_scale": ({"q_scale": [0.25, 0.5, 1, 2, 5, 20, 100]}, {"keep_errors": True}),
    "r_scale": ({"r_scale": [0.25, 0.5, 1, 2, 5, 20, 100]}, {}),
    "threshold": ({"threshold": [0.0, 0.1, 0.2, 1 / 3, 0.5, 0.7, 1.0]}, {}),
    "scheme": ({"scheme": ["multinomial", "residual", "stratified", "systematic"]}, {}),
    "gap": ({"gap": [None, GAP]}, {"n_steps": 260, "keep_errors": True}),
    "dt_meas": ({"dt_meas": [1.0, 2.0, 5.0, 10.0, 20.0]}, {"n_steps": 200}),
    "n_landmarks": ({"n_landmarks": [1, 2, 3, 5, 10, 30]}, {}),
    "initial": ({"initial": ["tracking", "uniform"], "n_particles": [300, 1000]}, {"n_steps": 50}),
}
#: Per-step columns of ``pf_run(..., keep_errors=True)``.
ARRAY_COLUMNS = ("position_error", "position_sd", "heading_error")


def _literal_columns(name: str) -> list[str]:
    """Grid columns whose values are not all numbers (stored as Python literals)."""
    return [column for column, values in STUDIES[name][0].items()
            if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)]


def run_function(name: str):
    """The run function of study ``name``: ``pf_run`` with the defaults and the study's options."""
    if name not in STUDIES:
        raise ParameterError(f"unknown robot study {name!r}; known: {list(STUDIES)}")
    return partial(pf_run, **{**DEFAULTS, **STUDIES[name][1]})


def compute(name: str, n_runs: int = N_RUNS, **options) -> pd.DataFrame:
    """Run study ``name`` (``options`` go to :func:`run_study`: ``executor``, ``progress``)."""
    run_one = run_function(name)  # refuses an unknown name
    return run_study(run_one, STUDIES[name][0], n_runs, **{"progress": False, **options})


def save(name: str, table: pd.DataFrame, folder: Path = DATA) -> None:
    """Write ``table`` as ``folder/NAME.csv`` (and ``NAME.npz`` for its per-step columns)."""
    folder.mkdir(parents=True, exist_ok=True)
    arrays = [c for c in ARRAY_COLUMNS if c in table.columns]
    scalars = table.drop(columns=arrays).copy()
    for column in _literal_columns(name):  # None, tuples, names: written as Python literals
        scalars[column] = scalars[column].map(repr)
    scalars.to_csv(folder / f"{name}.csv", index=False)
    if arrays:
        width = max(len(v) for v in table[arrays[0]] if isinstance(v, np.ndarray))
        stacked = {}
        for column in arrays:
            out = np.full((len(table), width), np.nan)
            for i, value in enumerate(table[column]):
                if isinstance(value, np.ndarray):
                    out[i] = value
            stacked[column] = out
        np.savez_compressed(folder / f"{name}.npz", **stacked)


def load(name: str, folder: Path = DATA) -> pd.DataFrame:
    """Study ``name`` as :func:`compute` returns it (per-step columns as arrays; ``seconds`` as stored)."""
    path = folder / f"{name}.csv"
    if name not in STUDIES:
        raise ParameterError(f"unknown robot study {name!r}; known: {list(STUDIES)}")
    if not path.exists():
        raise FileNotFoundError(f"{path} is missing: run `python3 tasks.py study robot_studies`")
    table = pd.read_csv(path,  # floats round-trip exactly (pandas >= 3 parses them precisely)
                        converters={column: ast.literal_eval for column in _literal_columns(name)})
    table["error"] = ["" if isinstance(v, float) else v for v in table["error"]]  # read back as NaN
    arrays_path = folder / f"{name}.npz"
    if arrays_path.exists():
        with np.load(arrays_path) as arrays:
            for column in ARRAY_COLUMNS:
                rows = arrays[column]
                table[column] = [row if ok == "ok" else np.nan for row, ok in zip(rows, table["status"])]
    return table


def find(grid: dict, **options) -> pd.DataFrame:
    """The stored study with exactly this grid and these ``pf_run`` options (besides DEFAULTS).

    Lets a chapter state each study as it would run it, ``find({"r_scale": [...]})``, and read
    the stored table; a grid or options that no stored study has are refused with a
    :class:`~pfcourse.errors.ParameterError` (run them with ``run_study`` instead), so the
    chapter cannot drift from the data.
    """
    for name, (stored_grid, stored_options) in STUDIES.items():
        if stored_grid == grid and stored_options == options:
            return load(name)
    raise ParameterError(f"no stored robot study has grid {grid} and options {options}; "
                         f"stored: {list(STUDIES)} (pfcourse.experiments.robot_studies.STUDIES)")
