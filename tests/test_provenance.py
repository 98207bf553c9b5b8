"""pfcourse.experiments.provenance: every stored study records the same fields, rows round-trip."""

from __future__ import annotations

import csv
import json

import numpy as np

from pfcourse.experiments.provenance import launch_commit, write_provenance, write_rows


def test_provenance_records_commit_versions_and_the_study_fields(tmp_path):
    commit = launch_commit()
    record = write_provenance(tmp_path / "x.json", code="tools/studies/x.py", commit=commit, seconds=1.234,
                              seeds="run r uses seed r", settings={"n": [1, 2]})
    assert json.loads((tmp_path / "x.json").read_text()) == record
    assert len(record["git_commit"]) == 40 and record["git_commit"] == commit
    assert record["wall_seconds"] == 1.2 and record["numpy"] == np.__version__
    assert isinstance(record["working_tree_modified"], bool)
    assert record["settings"] == {"n": [1, 2]} and record["seeds"] == "run r uses seed r"


def test_rows_round_trip_floats_exactly(tmp_path):
    values = np.random.default_rng(0).normal(size=50) * 10.0 ** np.arange(-25, 25)
    write_rows(tmp_path / "r.csv", [{"run": i, "x": float(v)} for i, v in enumerate(values)])
    with open(tmp_path / "r.csv", newline="") as f:
        back = list(csv.DictReader(f))
    assert [float(r["x"]) for r in back] == list(values)
    assert [int(r["run"]) for r in back] == list(range(50))
