"""Part III's stored robot studies (book/data/robot_studies/): their provenance, and the chapter's
grids are exactly the stored ones (tests/test_stored_studies.py re-runs a seeded sample of rows
and checks that each table has every setting and run).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from pfcourse.errors import ParameterError
from pfcourse.studies import robot_studies as rs
from pfcourse.studies.registry import robot_study


def test_provenance_records_the_seeds_and_settings():
    record = json.loads((rs.DATA / "provenance.json").read_text())
    assert record["n_runs"] == rs.N_RUNS
    assert {name.split("/")[-1] for name in record["studies"]} == set(rs.STUDIES)  # (registry: robot_studies/NAME)
    assert record["git_commit"] and "replicate_seed(0, r)" in record["seeds"]


def test_robot_study_reads_the_stored_study_and_refuses_others():
    table = robot_study({"scheme": ["multinomial", "residual", "stratified", "systematic"]})
    assert set(table["scheme"]) == {"multinomial", "residual", "stratified", "systematic"}
    assert table.attrs["provenance"] == json.loads((rs.DATA / "provenance.json").read_text())  # and its provenance
    with pytest.raises(ParameterError, match="no stored robot study"):
        robot_study({"r_scale": [1, 2]})
    with pytest.raises(ParameterError, match="no stored robot study"):
        robot_study({"q_scale": [0.25, 0.5, 1, 2, 5, 20, 100]})  # stored with keep_errors=True


def test_robot_studies_do_not_import_the_registry():
    """The registry is built from robot_studies.STUDIES; the reader lives in the registry (no cycle)."""
    import ast
    tree = ast.parse(Path(rs.__file__).read_text())
    imported = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert not any(m and m.endswith(".registry") for m in imported)
