"""book/data/terrain_studies.csv is what pfcourse.experiments.terrain_studies computes.

A seeded random sample of stored rows is re-computed and must give the same numbers; the
baseline's rows are the regularised N = 30000 rows of book/data/terrain_remedies.csv (same
flights, same filter seeds).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pfcourse.errors import ParameterError
from pfcourse.experiments import terrain_studies as ts
from pfcourse.terrain.map import load_jacksboro

DATA = Path(__file__).resolve().parents[1] / "book" / "data"
TABLE = pd.read_csv(DATA / "terrain_studies.csv")
# the 10 Hz runs take seconds each: sampled among the others
CHEAP = TABLE[TABLE["setting"] != "every 0.1 s, dt = 0.1 s"]
SAMPLE = CHEAP.iloc[np.random.default_rng(2026).choice(len(CHEAP), size=3, replace=False)]


@pytest.fixture(scope="module")
def terrain():
    return load_jacksboro()


def test_every_setting_has_every_flight_and_its_provenance():
    meta = json.loads((DATA / "terrain_studies.json").read_text())
    assert meta["code"] == "tools/studies/terrain_studies.py" and len(meta["git_commit"]) == 40
    counts = TABLE.groupby(["study", "setting"]).size()
    assert set(counts.index) == set(ts.settings())
    assert (counts == meta["n_flights"]).all()


@pytest.mark.parametrize("row", list(SAMPLE.itertuples(index=False)), ids=lambda r: f"{r.setting}-{r.flight}")
def test_sampled_rows_are_recomputed(row, terrain):
    fresh = ts.study_row(row.study, row.setting, int(row.flight), terrain)
    for key in ("final_error", "mean_error", "sigma_50", "sigma_75", "median_ess_fraction"):
        np.testing.assert_allclose(fresh[key], getattr(row, key), rtol=1e-9, err_msg=key)
    assert fresh["lost"] == bool(row.lost) and fresh["resamplings"] == row.resamplings


def test_baseline_rows_are_the_regularised_rows_of_the_remedies_table():
    remedies = pd.read_csv(DATA / "terrain_remedies.csv")
    reg = remedies[remedies["setting"] == "regularised N=30000"].set_index("flight")
    base = TABLE[TABLE["study"] == "baseline"].set_index("flight")
    common = base.index.intersection(reg.index)
    assert len(common) == len(base)
    np.testing.assert_allclose(base.loc[common, "final_error"], reg.loc[common, "final_error"], rtol=1e-9)
    assert (base.loc[common, "lost"].astype(bool) == reg.loc[common, "lost"].astype(bool)).all()


def test_unknown_settings_are_named():
    with pytest.raises(ParameterError, match="unknown study/setting"):
        ts.configure("Qf", "Qf x 3")
