"""Part III's stored robot studies (book/data/robot_studies/) are what their code computes.

A seeded sample of rows is re-run from the recorded seeds and must give the same numbers,
float for float (the pinned arithmetic, tests/test_arithmetic.py); the tables have one row
per setting and run; the chapter's grids are exactly the stored ones.
"""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from pfcourse.errors import ParameterError
from pfcourse.experiments import robot_studies as rs
from pfcourse.seeding import replicate_seed

SAMPLE = np.random.default_rng(20261123)


@pytest.mark.parametrize("name", list(rs.STUDIES))
def test_table_has_every_setting_and_run(name):
    table = rs.load(name)
    grid = rs.STUDIES[name][0]
    settings = list(itertools.product(*grid.values()))
    assert len(table) == len(settings) * rs.N_RUNS
    assert sorted(table["run"]) == sorted(list(range(rs.N_RUNS)) * len(settings))
    assert set(table["seed"]) == {replicate_seed(0, r) for r in range(rs.N_RUNS)}
    assert (table["status"] == "ok").mean() > 0.5


@pytest.mark.parametrize("name", list(rs.STUDIES))
def test_a_seeded_sample_of_rows_is_reproduced(name):
    """Two rows per study, drawn with a fixed seed, re-run with pf_run: the same numbers."""
    table = rs.load(name)
    grid = rs.STUDIES[name][0]
    run = rs.run_function(name)
    for i in SAMPLE.choice(len(table), 2, replace=False):
        row = table.iloc[int(i)]
        setting = {column: row[column] for column in grid}
        if row["status"] != "ok":
            with pytest.raises(Exception):
                run(int(row["seed"]), **setting)
            continue
        fresh = run(int(row["seed"]), **setting)
        for metric, value in fresh.items():
            if isinstance(value, np.ndarray):
                np.testing.assert_array_equal(row[metric], value, err_msg=f"{name} row {i}: {metric}")
            else:
                assert row[metric] == value, f"{name} row {i} {setting}: {metric} {row[metric]!r} != {value!r}"


def test_provenance_records_the_seeds_and_settings():
    record = json.loads((rs.DATA / "provenance.json").read_text())
    assert record["n_runs"] == rs.N_RUNS
    assert set(record["studies"]) == set(rs.STUDIES)
    assert record["git_commit"] and "replicate_seed(0, r)" in record["seeds"]


def test_find_returns_the_stored_study_and_refuses_others():
    table = rs.find({"scheme": ["multinomial", "residual", "stratified", "systematic"]})
    assert set(table["scheme"]) == {"multinomial", "residual", "stratified", "systematic"}
    with pytest.raises(ParameterError, match="no stored robot study"):
        rs.find({"r_scale": [1, 2]})
    with pytest.raises(ParameterError, match="no stored robot study"):
        rs.find({"q_scale": [0.25, 0.5, 1, 2, 5, 20, 100]})  # stored with keep_errors=True
    with pytest.raises(ParameterError, match="unknown robot study"):
        rs.load("nope")
