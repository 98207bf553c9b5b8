"""Part III's robot studies: their settings, and their tables stored under ``book/data/robot_studies/``.

Each study runs :func:`pfcourse.studies.robot.pf_run` over one grid, ``N_RUNS`` seeded
runs per setting (run ``r`` has seed ``replicate_seed(0, r)`` in every study: common random
numbers), through :func:`pfcourse.studies.study.run_study`. Together they take about
50 s on two cores, a sixth of the book's execution budget, so they are registered studies
(``robot_studies/NAME`` in :mod:`pfcourse.studies.registry`), run once by
``python3 tasks.py study robot_studies`` and stored; the chapter reads them
(:func:`pfcourse.studies.registry.robot_study`, which reads ``STUDIES[...].load()``),
and ``tests/test_stored_studies.py`` re-runs a seeded sample of rows and requires the
same numbers.

A table is stored (:mod:`pfcourse.studies.store`) as ``NAME.csv`` (one row per run: the
setting, ``run``, ``seed``, ``status``, ``error`` and the scalar metrics, floats written to
round-trip exactly; settings that are neither numbers nor words, ``None`` and tuples, written as
Python literals) and, for the
studies that keep per-step errors, ``NAME.npz`` (one 2-D array per per-step column, one row
per table row; a failed run's row is NaN).
"""

from __future__ import annotations

from pathlib import Path


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
    "initial": ({"initial": ["tracking", "uniform"], "n_particles": [300, 1000]}, {"n_steps": 50, "keep_errors": True}),
}
#: Per-step columns of ``pf_run(..., keep_errors=True)``.
ARRAY_COLUMNS = ("position_error", "position_sd", "heading_error")

