"""Part III's stored robot studies (book/data/robot_studies/): their provenance, and the chapter's
grids are exactly the stored ones (tests/test_stored_studies.py re-runs a seeded sample of rows
and checks that each table has every setting and run).
"""

from __future__ import annotations

import json

import pytest

from pfcourse.errors import ParameterError
from pfcourse.experiments import robot_studies as rs


def test_provenance_records_the_seeds_and_settings():
    record = json.loads((rs.DATA / "provenance.json").read_text())
    assert record["n_runs"] == rs.N_RUNS
    assert {name.split("/")[-1] for name in record["studies"]} == set(rs.STUDIES)  # (registry: robot_studies/NAME)
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
