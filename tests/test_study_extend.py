"""registry.extend: a stored study's later runs appended to its table give the table a full run gives.

A row depends only on its seed, so runs 0-5 stored in one go and runs 6-9 appended in another must be the
table of one run of 0-9, row for row and float for float (wall times excepted); the provenance lists both
goes with their seeds. A study extend cannot append to honestly (a grid, a provenance shared with other
studies, stored rows that are not its first runs in order) is refused by name.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from pfcourse.errors import ParameterError
from pfcourse.studies import registry
from pfcourse.studies.executor import SerialExecutor
from pfcourse.studies.registry import Study


def toy_row(seed: int) -> dict:
    rng = np.random.default_rng([7, seed])
    return {"x": float(rng.normal()), "hit": bool(rng.random() < 0.5)}


def toy_grid_row(seed: int, a: int) -> dict:
    return {"x": float(a + seed)}


@pytest.fixture
def data(tmp_path, monkeypatch):
    monkeypatch.setattr(registry, "DATA", tmp_path)
    monkeypatch.setattr(registry, "launch_commit", lambda: "b" * 40)
    return tmp_path


def toy(n_runs: int, name: str = "toy/one", provenance: str = "toy_one.json", grid=None, row=toy_row) -> Study:
    return Study(name=name, row=row, grid={} if grid is None else grid, n_runs=n_runs, seeds="run", base_seed=150,
                 failures="raise", table=f"{name.replace('/', '_')}.csv", provenance=provenance,
                 columns=("seed", "x", "hit") if grid is None else None, fields={"seeds": "run s"})


def store_first_go(study: Study, data, n: int) -> pd.DataFrame:
    first = study.compute(n, executor=SerialExecutor())
    study.save(first)
    (data / study.provenance).write_text(json.dumps({"git_commit": "a" * 40, "working_tree_modified": False,
                                                     "date_utc": "2026-11-27T15:00:00+00:00", "wall_seconds": 3.0,
                                                     "code": "x", "row_code": "y", "n_runs": n, "rows": n}))
    return first


def test_appended_runs_give_the_table_of_one_full_run(data, monkeypatch):
    study = toy(10)
    monkeypatch.setitem(registry.STUDIES, study.name, study)
    store_first_go(study, data, 6)
    registry.extend(study.name, 10, executor=SerialExecutor())
    full = study.compute(10, executor=SerialExecutor())
    extended = study.load()
    assert list(extended["seed"]) == list(range(150, 160))
    pd.testing.assert_frame_equal(extended.drop(columns="seconds", errors="ignore"),
                                  full.drop(columns="seconds", errors="ignore"), check_exact=True, check_dtype=False)
    record = json.loads((data / study.provenance).read_text())
    assert "git_commit" not in record and record["n_runs"] == 10 and record["rows"] == 10
    assert [(go["commit"], go["runs"], go["seeds"]) for go in record["runs"]] == [
        ("a" * 40, "0-5", "150-155"), ("b" * 40, "6-9", "156-159")]


def test_compute_from_a_later_run_gives_those_rows_of_the_full_table():
    study = toy(8)
    full, tail = study.compute(8, executor=SerialExecutor()), study.compute(8, first=5, executor=SerialExecutor())
    assert list(tail["seed"]) == [155, 156, 157]
    assert tail["x"].tolist() == full["x"].iloc[5:].tolist()
    with pytest.raises(ParameterError, match="first run 8"):
        study.compute(8, first=8)


def test_extend_refuses_what_it_cannot_append_honestly(data, monkeypatch):
    grid = toy(4, name="toy/grid", provenance="toy_grid.json", grid={"a": [1, 2]}, row=toy_grid_row)
    shared = [toy(4, name=f"toy/shared{i}", provenance="toy_shared.json") for i in (1, 2)]
    shuffled = toy(6, name="toy/shuffled", provenance="toy_shuffled.json")
    for study in (grid, *shared, shuffled):
        monkeypatch.setitem(registry.STUDIES, study.name, study)
    for study in (grid, shared[0]):
        with pytest.raises(ParameterError, match="only a study with its own provenance file and no grid"):
            registry.extend(study.name, 8)
    first = store_first_go(shuffled, data, 3)
    shuffled.save(first.iloc[::-1].reset_index(drop=True))
    with pytest.raises(ParameterError, match="not its runs 0 .. 2 in order"):
        registry.extend(shuffled.name, 6)
