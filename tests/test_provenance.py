"""pfcourse.studies.provenance: every stored study records the same fields, rows round-trip."""

from __future__ import annotations

import csv
import json

import numpy as np

from pfcourse.studies.provenance import launch_commit, write_provenance, write_rows


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


def _row(seed, x):
    return {"value": float(seed + x)}


def test_a_rerun_of_one_study_of_a_group_is_appended_to_the_groups_record(tmp_path, monkeypatch):
    """``tasks.py study group/one`` keeps the group's shared record and appends the re-run to its
    ``reruns`` list; the whole group writes the record afresh (studies on a temporary DATA)."""
    from pfcourse.studies import registry

    studies = {name: registry.Study(name=name, row=_row, grid={"x": [1, 2]}, n_runs=2, seeds="run",
                                    table=f"group/{name.split('/')[1]}.csv", provenance="group/provenance.json",
                                    row_code="tests/test_provenance.py (_row)")
               for name in ("group/a", "group/b")}
    monkeypatch.setattr(registry, "STUDIES", studies)
    monkeypatch.setattr(registry, "DATA", tmp_path)
    (tmp_path / "group").mkdir()
    path = tmp_path / "group" / "provenance.json"
    registry.run("group")
    group_record = json.loads(path.read_text())
    assert set(group_record["studies"]) == {"group/a", "group/b"} and "reruns" not in group_record
    registry.run("group/b")
    registry.run("group/b")
    record = json.loads(path.read_text())
    reruns = record.pop("reruns")
    assert record == group_record
    assert [entry["study"] for entry in reruns] == ["b", "b"]
    assert all(entry["rows"] == 4 and len(entry["git_commit"]) == 40 and entry["file"] == "b.csv" for entry in reruns)
    registry.run("group")  # the whole group again: a fresh record
    assert "reruns" not in json.loads(path.read_text())
