"""Every registered study's stored table (book/data/) is what its record computes.

For each study of pfcourse.studies.registry: the stored table has exactly the rows its
record describes (every setting, every run's seed, in order) and a provenance record; a
seeded sample of its cheap rows is re-run from the recorded setting and seed and must give
the same numbers, float for float (the pinned arithmetic, tests/test_arithmetic.py), wall
times excepted; the store reads back what it writes.
"""

from __future__ import annotations

import dataclasses
import json
import zlib

import numpy as np
import pandas as pd
import pytest

from pfcourse.errors import DegenerateWeightsError, ParameterError, StepError
from pfcourse.filter_config import FilterSettings
from pfcourse.studies.registry import STUDIES, Study, same, select
from pfcourse.studies.store import DATA, load, save

REGISTERED = list(STUDIES.values())
IDS = [study.name for study in REGISTERED]


@pytest.mark.parametrize("study", REGISTERED, ids=IDS)
def test_stored_table_has_every_setting_and_seed_in_order(study: Study):
    stored, layout = study.load(), study.layout()
    assert len(stored) == len(layout)
    for key in {key for grid in study.grids for key in grid}:
        assert all(same(a, b) for a, b in zip(stored[key], layout[key])), key
    assert list(stored[study.seed_column]) == list(layout["seed"])
    record = json.loads((DATA / study.provenance).read_text())
    commits = [record["git_commit"]] if "git_commit" in record else [run["commit"] for run in record["runs"]]
    assert commits and all(len(commit) == 40 for commit in commits)  # (terrain_remedies ran in several goes)


@pytest.mark.parametrize("study", REGISTERED, ids=IDS)
def test_a_seeded_sample_of_stored_rows_is_recomputed(study: Study):
    stored = study.load()
    candidates = stored[study.cheap(stored)] if study.cheap is not None else stored
    rng = np.random.default_rng([2026, zlib.crc32(study.name.encode())])
    for i in rng.choice(len(candidates), study.sample, replace=False):
        row = candidates.iloc[int(i)]
        if "status" in row and row["status"] != "ok":
            with pytest.raises(StepError):
                study.recompute(row)
            continue
        fresh = study.recompute(row)
        for key, value in fresh.items():
            if key in stored.columns and key not in study.volatile:
                assert same(row[key], value), f"{study.name} row {row.name}: {key} {row[key]!r} != {value!r}"


def test_the_store_round_trips_every_kind_of_column(tmp_path):
    values = np.random.default_rng(0).normal(size=6) * 10.0 ** np.arange(-15, 15, 5)
    table = pd.DataFrame({"gap": [None, (1.0, 2.0), None, (1.0, 2.0), None, None], "x": values,
                          "name": list("abcdef"), "run": range(6), "status": ["ok"] * 5 + ["failed"],
                          "error_message": [""] * 5 + ["StepError: lost"], "lost": [True, False] * 3,
                          "trace": [np.arange(3.0) * v for v in values[:5]] + [np.nan]})
    save(tmp_path / "t.csv", table, literals=["gap"], arrays=["trace"])
    back = load(tmp_path / "t.csv", literals=["gap"], arrays=["trace"])
    pd.testing.assert_frame_equal(back.drop(columns="trace"), table.drop(columns="trace"), check_exact=True)
    assert all(same(a, b) for a, b in zip(back["trace"], table["trace"]))


def test_a_metric_named_error_reads_back_as_numbers_and_empty_messages_as_text(tmp_path):
    """run_study's messages are in ``error_message`` (an ok run's is empty, read back as ""); a metric named
    ``error`` (static_parameters, sir_fixes) is a metric like any other, its numbers read back as numbers,
    even beside the messages of a table with failed runs."""
    table = pd.DataFrame({"run": range(3), "status": ["ok", "ok", "failed"], "error_message": ["", "", "StepError: x"],
                          "error": [0.25, 0.125, np.nan]})
    save(tmp_path / "m.csv", table)
    back = load(tmp_path / "m.csv")
    assert back["error"].iloc[0] == 0.25 and back["error"].iloc[1] == 0.125 and np.isnan(back["error"].iloc[2])
    assert list(back["error_message"]) == ["", "", "StepError: x"]
    messages = pd.DataFrame({"run": range(3), "status": ["ok"] * 3, "error_message": ["", "", ""]})
    save(tmp_path / "e.csv", messages)
    assert list(load(tmp_path / "e.csv")["error_message"]) == ["", "", ""]


def test_a_row_may_return_a_metric_named_error_beside_run_study_s_messages():
    from pfcourse.studies.executor import SerialExecutor
    from pfcourse.studies.study import run_study

    table = run_study(lambda seed, a: {"error": seed * 0.5}, {"a": [1]}, 2, seeds=[1, 2], executor=SerialExecutor(),
                      progress=False)
    assert list(table["error"]) == [0.5, 1.0] and list(table["error_message"]) == ["", ""]


def test_unknown_names_and_rules_are_refused():
    with pytest.raises(ParameterError, match="unknown study"):
        select("nope")
    assert len(select("robot_studies")) == 9
    with pytest.raises(ParameterError, match="seeds must be one of"):
        Study(name="x", row=dict, grid={"a": [1]}, n_runs=1, table="x.csv", provenance="x.json", seeds="random")


def _toy_row(seed, a, b):
    if a == 3 and seed == 6:
        raise StepError("lost")
    return {"x": seed * 0.1 + a, "label": f"{a}{b}"}


def test_a_study_is_run_stored_and_recorded_by_name(tmp_path, monkeypatch):
    """`tasks.py study NAME` end to end on a toy group: tables, order, failures, provenance."""
    import pfcourse.studies.registry as registry

    monkeypatch.setattr(registry, "DATA", tmp_path)
    toys = [Study(name="toy/one", row=_toy_row, grid=({"a": [2], "b": ["p"]}, {"a": [1, 3], "b": ["q"]}), n_runs=2,
                  seeds="run", base_seed=5, table="toy/one.csv", provenance="toy/provenance.json", order=("run",),
                  filters={"bootstrap": FilterSettings(10, threshold=1.0)}),
            Study(name="toy/two", row=_toy_row, grid={"a": [1], "b": ["r"]}, n_runs=3, table="toy/two.csv",
                  provenance="toy/provenance.json", columns=("a", "b", "seed", "x"))]
    for toy in toys:
        monkeypatch.setitem(registry.STUDIES, toy.name, toy)
    assert registry.main(["toy"]) == 0
    one, two = (toy.load() for toy in toys)
    assert list(zip(one["a"], one["seed"])) == [(2, 5), (1, 5), (3, 5), (2, 6), (1, 6), (3, 6)] == \
        list(zip(toys[0].layout()["a"], toys[0].layout()["seed"]))
    assert list(one["status"]) == ["ok"] * 5 + ["failed"] and one["error_message"].iloc[0] == ""
    assert list(two.columns) == ["a", "b", "seed", "x"]
    assert same(two.iloc[1]["x"], toys[1].recompute(two.iloc[1])["x"])
    record = json.loads((tmp_path / "toy" / "provenance.json").read_text())
    assert record["code"] == "pfcourse/studies/registry.py" and set(record["studies"]) == {"toy/one", "toy/two"}
    assert record["studies"]["toy/one"]["seeds"] == "run r: seed 5 + r" and "n_runs" not in record
    # the filters of the group's studies, as settings records, per study and at the top (the one schema)
    assert record["studies"]["toy/one"]["filters"] == record["filters"] == toys[0].filter_records()
    assert record["filters"]["bootstrap"]["threshold"] == 1.0 and record["studies"]["toy/two"]["filters"] == {}
    with pytest.raises(StepError, match="toy/one"):
        registry.Study(**{**toys[0].__dict__, "failures": "raise"}).compute()


def _collapse(seed, **setting):
    raise DegenerateWeightsError("every particle has zero likelihood", step=7)


@pytest.mark.parametrize("name", ["terrain_remedies", "terrain_studies", "terrain_error_paths", "terrain_mpf",
                                  "terrain_confirmation", "global_localization/lockon"])
def test_a_filter_that_loses_every_particle_is_recorded_by_the_runner(name):
    """No row function catches a collapse: the study runner records it (status failed, its message) with the
    study's failed scores (a terrain flight lost at an infinite error, a global run not locked on), and the
    row keeps its seed and setting columns; the table has the stored columns."""
    study = STUDIES[name]
    table = dataclasses.replace(study, row=_collapse).compute(n_runs=2)
    stored = study.load()
    assert list(table.columns) == list(study.columns) and set(table.columns) == set(stored.columns)
    assert (table["status"] == "failed").all() and table["error_message"].str.startswith("DegenerateWeightsError: every particle").all()
    assert list(table[study.seed_column]) == list(study.layout(n_runs=2)["seed"])
    for column, value in study.failed_scores.items():
        assert all(same(v, value) for v in table[column]), column
    if "final_error" in table:
        assert np.isinf(table["final_error"]).all()
    assert "lost" not in table or table["lost"].all()


def test_the_schema_is_derived_not_declared():
    """Literal columns are the grid's values that are neither numbers nor words; every table's floats
    round-trip (no rounded table is left); a grid parameter cannot take the name of the run or its seed."""
    assert STUDIES["robot_studies/gap"].literals == ("gap",) and STUDIES["robot_studies/scheme"].literals == ()
    assert not hasattr(Study, "stored_rtol")
    with pytest.raises(ParameterError, match="cannot be named"):
        Study(name="x", row=dict, grid={"seed": [1]}, n_runs=1, table="x.csv", provenance="x.json")
    legacy = {"stored_as", "literals", "errors_as_text", "rtol"} & {f.name for f in dataclasses.fields(Study)}
    assert not legacy, legacy


def test_failed_scores_need_the_record_policy():
    with pytest.raises(ParameterError, match="failed_scores"):
        Study(name="x", row=dict, grid={"a": [1]}, n_runs=1, table="x.csv", provenance="x.json", failures="raise",
              failed_scores={"lost": True})
