"""Every registered study's stored table (book/data/) is what its record computes.

For each study of pfcourse.experiments.registry: the stored table has exactly the rows its
record describes (every setting, every run's seed, in order) and a provenance record; a
seeded sample of its cheap rows is re-run from the recorded setting and seed and must give
the same numbers, float for float (the pinned arithmetic, tests/test_arithmetic.py), wall
times excepted; the store reads back what it writes.
"""

from __future__ import annotations

import json
import zlib

import numpy as np
import pandas as pd
import pytest

from pfcourse.errors import ParameterError, StepError
from pfcourse.experiments.registry import STUDIES, Study, same, select
from pfcourse.experiments.store import DATA, load, save

REGISTERED = list(STUDIES.values())
IDS = [study.name for study in REGISTERED]


@pytest.mark.parametrize("study", REGISTERED, ids=IDS)
def test_stored_table_has_every_setting_and_seed_in_order(study: Study):
    stored, layout = study.load(), study.layout()
    assert len(stored) == len(layout)
    for key in {key for grid in study.grids for key in grid}:
        assert all(same(a, b) for a, b in zip(stored[study.stored_as.get(key, key)], layout[key])), key
    if study.seed_column is not None:
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
                          "error": [""] * 5 + ["StepError: lost"], "lost": [True, False] * 3,
                          "trace": [np.arange(3.0) * v for v in values[:5]] + [np.nan]})
    save(tmp_path / "t.csv", table, literals=["gap"], arrays=["trace"])
    back = load(tmp_path / "t.csv", literals=["gap"], arrays=["trace"], errors_as_text=True)
    pd.testing.assert_frame_equal(back.drop(columns="trace"), table.drop(columns="trace"), check_exact=True)
    assert all(same(a, b) for a, b in zip(back["trace"], table["trace"]))


def test_unknown_names_and_rules_are_refused():
    with pytest.raises(ParameterError, match="unknown study"):
        select("nope")
    assert len(select("robot_studies")) == 9
    with pytest.raises(ParameterError, match="seeds must be one of"):
        Study(name="x", row=dict, grid={"a": [1]}, n_runs=1, table="x.csv", provenance="x.json", seeds="random")
